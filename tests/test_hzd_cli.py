"""``vsw hzd``: its JSON keys and units, and bad input (one line, exit 2): constraints
that leave other than one degree of freedom, outputs that are not one per input or not
affine, a decoupling matrix that is singular on the surface, a phase variable that does not
run from theta_plus to theta_minus, a gait whose zeta reaches 0, a model without inputs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from vsw.cli import main

pytest.importorskip("casadi")

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "hzd"
MIRROR = EXAMPLES / "three_link_mirror.py"
INVARIANT = EXAMPLES / "three_link_mirror_invariant.py"


def test_cli_json(capsys):
    code = main(["hzd", "--model", "three-link-biped", "--constraints", str(INVARIANT),
                 "--json"])  # fmt: skip
    out, err = capsys.readouterr()
    assert code == 0, err
    data = json.loads(out)
    for name in ("delta", "delta_squared", "V", "zeta_star", "theta_dot_minus",
                 "theta_dot_plus", "period", "step_length", "speed", "impact_invariance",
                 "work_per_step", "impact_loss", "peak_torques", "full_order"):  # fmt: skip
        assert name in data
    assert set(data["full_order"]) >= {"theta_dot_minus", "period", "eigenvalues"}
    assert data["units"]["quantities"]["zeta_star"] == "(kg m^2/s)^2"
    assert data["units"]["quantities"]["peak_torques.torso_stance_torque"] == "N m"


BAD = {
    "dependent": ("{theta2: -THETA, theta1: THETA}", "degrees of freedom"),
    "too few outputs": ("{theta3: sm.pi / 6}", "one output per input"),
    "not affine": ("{theta2: -THETA, sm.sin(theta3): sm.pi / 6}", "affine"),
    "singular decoupling": (
        "{theta2: -THETA + (THETA**2 - END**2) / 2, theta3: sm.pi/6 - 8*(THETA**2 - END**2)}",
        "decoupling matrix",
    ),
    "stops": ("{theta2: -THETA + (THETA**2 - END**2) / 2, theta3: -sm.pi / 6}", "zeta reaches 0"),
}


def _constraints(tmp_path: Path, outputs: str, phase: str = "theta1",
                 ends: str = "-END, END") -> Path:  # fmt: skip
    path = tmp_path / "constraints.py"
    plus, minus = ends.split(",")
    path.write_text(
        "import sympy as sm\n"
        "from derive.hzd import THETA, Constraints, coordinates\n"
        'theta1, theta2, theta3 = coordinates("theta1", "theta2", "theta3")\n'
        "END = sm.pi / 8\n"
        f"CONSTRAINTS = Constraints(phase={phase}, theta_plus={plus}, theta_minus={minus}, "
        f"outputs={outputs})\n"
    )
    return path


def _one_line_exit_2(capsys, argv: list[str], words: str) -> None:
    code = main(argv)
    _out, err = capsys.readouterr()
    assert code == 2, err
    assert err.count("\n") == 1 and words in err, err
    assert "Traceback" not in err


@pytest.mark.parametrize("case", list(BAD), ids=list(BAD))
def test_bad_constraints_one_line_exit_2(capsys, tmp_path, case):
    outputs, words = BAD[case]
    path = _constraints(tmp_path, outputs)
    _one_line_exit_2(capsys, ["hzd", "--model", "three-link-biped", "--constraints", str(path)],
                     words)  # fmt: skip


def test_phase_running_backward_is_refused(capsys, tmp_path):
    path = _constraints(tmp_path, "{theta2: -THETA, theta3: sm.pi / 6}", ends="END, -END")
    _one_line_exit_2(capsys, ["hzd", "--model", "three-link-biped", "--constraints", str(path)],
                     "not monotonic")  # fmt: skip


def test_theta_plus_not_the_impacts_is_refused(capsys, tmp_path):
    path = _constraints(tmp_path, "{theta2: -THETA, theta3: sm.pi / 6}", ends="-0.3, END")
    _one_line_exit_2(capsys, ["hzd", "--model", "three-link-biped", "--constraints", str(path)],
                     "theta_plus")  # fmt: skip


def test_model_without_inputs_and_missing_file(capsys, tmp_path):
    _one_line_exit_2(capsys, ["hzd", "--model", "rimless-wheel", "--constraints", str(MIRROR)],
                     "no inputs")  # fmt: skip
    _one_line_exit_2(capsys, ["hzd", "--model", "compass-gait", "--constraints", str(MIRROR)],
                     "one output per input")  # fmt: skip
    _one_line_exit_2(capsys, ["hzd", "--model", "three-link-biped", "--constraints",
                              str(tmp_path / "none.py")], "does not exist")  # fmt: skip


def test_bad_gains_are_a_usage_error(capsys):
    _one_line_exit_2(capsys, ["hzd", "--model", "three-link-biped", "--constraints",
                              str(MIRROR), "--gains", "400"], "KP,KD")  # fmt: skip


def test_examples_ship_in_the_sdist():
    """The examples the guide and these tests run are in the source distribution."""
    manifest = (EXAMPLES.parent.parent / "MANIFEST.in").read_text().split()
    assert "examples" in manifest[manifest.index("graft") :]
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == [
        "rabbit_walk.py",
        "three_link_mirror.py",
        "three_link_mirror_invariant.py",
    ]


# Slow tier: it derives the constraints twice in subprocesses (about 10 s of CPU alone).
@pytest.mark.slow
def test_constraints_are_derived_once_and_again_when_damaged(capsys, tmp_path, monkeypatch):
    """The package is cached by the file's digest; a damaged one is derived again."""
    monkeypatch.setenv("VSW_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "mirror.py"
    path.write_text(MIRROR.read_text())
    argv = ["hzd", "--model", "three-link-biped", "--constraints", str(path), "--json"]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    (package,) = (tmp_path / "cache" / "hzd").glob("mirror-*/hzd_constraints/__init__.py")
    stamp = package.stat().st_mtime_ns
    assert main(argv) == 0
    capsys.readouterr()
    assert package.stat().st_mtime_ns == stamp  # loaded, not derived again
    package.write_text(package.read_text().replace("def surface", "def damaged_surface"))
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["zeta_star"] == first["zeta_star"]


def test_cli_text_names_each_unit(capsys, tmp_path):
    plot = tmp_path / "hzd.svg"
    argv = ["hzd", "--model", "three-link-biped", "--constraints", str(MIRROR), "--plot", str(plot)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    lines = {line.split()[0]: line for line in out.splitlines()}
    assert lines["zeta_star"].endswith("(kg m^2/s)^2")
    assert lines["theta_dot_minus"].endswith("rad/s")
    assert lines["work_per_step"].endswith("J")
    assert "full-order gait          stable" in out
    assert plot.read_bytes().startswith(b"<?xml")


@pytest.mark.parametrize(
    ("text", "words"),
    [("import sympy\nx = 1 / 0\n", "ZeroDivisionError"), ("X = 1\n", "defines no CONSTRAINTS")],
    ids=["raises", "declares nothing"],
)
def test_a_file_that_fails_or_declares_nothing(capsys, tmp_path, text, words):
    path = tmp_path / "broken.py"
    path.write_text(text)
    _one_line_exit_2(capsys, ["hzd", "--model", "three-link-biped", "--constraints", str(path)],
                     words)  # fmt: skip
