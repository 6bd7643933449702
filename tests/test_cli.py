"""The vsw command line: JSON contract, exit codes and one-line errors."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from vsw.cli import main

ANALYZE = ["analyze", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45"]


def run_main(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def run_subprocess(argv):
    return subprocess.run(
        [sys.executable, "-m", "vsw", *argv], capture_output=True, text=True, timeout=120
    )


def test_analyze_json_contract_matches_paper_formulas(capsys):
    code, out, err = run_main(capsys, [*ANALYZE, "--json"])
    assert code == 0 and err == ""
    data = json.loads(out)
    for key in [
        "q_fixed", "omega_I", "eigenvalue", "theta_I", "theta_IV", "step_length",
        "step_period", "speed", "contact_margin", "walks", "conditions",
    ]:  # fmt: skip
        assert key in data
    beta, phi0 = 0.8, math.radians(45)
    theta_I = -math.atan((beta - math.cos(phi0)) / math.sin(phi0))  # eq. (11), radians
    c2 = math.cos(phi0) ** 2
    q_fixed = 2 * c2 * ((1 - beta**3) - math.cos(theta_I) * (beta - beta**3))
    q_fixed /= beta**2 * (1 - c2 * beta**2)  # eq. (10) at theta_II = 0
    assert data["q_fixed"] == pytest.approx(q_fixed, rel=1e-12)
    assert data["omega_I"] == pytest.approx(math.sqrt(q_fixed), rel=1e-12)
    assert data["theta_I"] == pytest.approx(theta_I, rel=1e-12)
    assert data["eigenvalue"] == pytest.approx(beta**2 * c2, rel=1e-12)
    assert data["walks"] is True
    assert "speed_m_s" not in data
    for c in data["conditions"]:
        assert {"name", "equation", "value", "holds"} <= c.keys()
    apex = next(c for c in data["conditions"] if c["name"] == "apex")
    assert apex["equation"] == "(14)"


def test_analyze_si_and_preset_agree(capsys):
    _, out, _ = run_main(capsys, [*ANALYZE, "--json", "--stepper-2d"])
    preset = json.loads(out)
    _, out, _ = run_main(
        capsys, [*ANALYZE, "--json", "--leg-length", "0.25", "--mass", "0.78", "--gravity", "9.81"]
    )
    explicit = json.loads(out)
    assert preset.pop("provenance")["command"] != explicit.pop("provenance")["command"]
    assert preset == explicit
    t_unit = math.sqrt(0.25 / 9.81)
    assert preset["step_period_s"] == pytest.approx(preset["step_period"] * t_unit, rel=1e-14)
    assert preset["speed_leg_s"] == pytest.approx(preset["speed_m_s"] / 0.25, rel=1e-14)
    assert preset["step_length_m"] == pytest.approx(preset["step_length"] * 0.25, rel=1e-14)


def test_analyze_table_by_default(capsys):
    code, out, err = run_main(capsys, ANALYZE)
    assert code == 0 and err == ""
    assert "q_fixed" in out and "walks" in out and "apex" in out
    with pytest.raises(json.JSONDecodeError):
        json.loads(out)


def test_non_walking_gait_gives_null_not_nan(capsys):
    code, out, _ = run_main(
        capsys, ["analyze", "--beta", "0.3", "--theta-ii", "0", "--phi0", "45", "--json"]
    )
    assert code == 0
    data = json.loads(out)  # strict parse: NaN would be invalid JSON
    assert data["walks"] is False
    assert data["step_period"] is None and data["speed"] is None


BAD_INPUTS = [
    [*ANALYZE[:-1], "95"],  # phi0 >= 90 deg, eq. (16)
    [*ANALYZE[:-1], "0"],
    ["analyze", "--beta", "1.0", "--theta-ii", "0", "--phi0", "45"],
    ["analyze", "--beta", "nan", "--theta-ii", "0", "--phi0", "45"],
    ["analyze", "--beta", "0.8", "--theta-ii", "inf", "--phi0", "45"],
    ["analyze", "--beta", "abc", "--theta-ii", "0", "--phi0", "45"],
    ["analyze", "--beta", "0.8", "--param", "theta_II=100deg"],
    [*ANALYZE, "--bogus"],
    [*ANALYZE, "--leg-length", "-1", "--mass", "1"],
    [*ANALYZE, "--leg-length", "0.25"],
    [*ANALYZE, "--stepper-2d", "--mass", "2"],
    [],
    ["fly"],
    [
        "simulate",
        "--beta",
        "0.8",
        "--theta-ii",
        "0",
        "--phi0",
        "45",
        "--q0",
        "-0.1",
        "--steps",
        "3",
    ],
    ["simulate", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45", "--q0", "0.3", "--steps", "0"],
    [
        "simulate",
        "--beta",
        "0.8",
        "--theta-ii",
        "0",
        "--phi0",
        "45",
        "--q0",
        "0.3",
        "--steps",
        "2.5",
    ],
    ["basin", "--beta", "0.8", "--phi0", "100"],
    ["basin", "--beta", "0.8", "--phi0", "45", "--theta-step", "0"],
]


@pytest.mark.parametrize("argv", BAD_INPUTS, ids=[" ".join(a) or "empty" for a in BAD_INPUTS])
def test_bad_input_exits_2_with_one_line(capsys, argv):
    code, out, err = run_main(capsys, argv)
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and err.strip()
    assert "Traceback" not in err


def test_domain_error_names_parameter_and_equation(capsys):
    _, _, err = run_main(capsys, [*ANALYZE[:-1], "95"])
    assert "phi0" in err and "95" in err and "eq. (16)" in err


def test_plot_in_missing_directory_is_bad_input(capsys, tmp_path):
    missing = str(tmp_path / "nope" / "q.png")
    argv = ["basin", "--beta", "0.8", "--phi0", "45", "--plot", missing]
    code, _, err = run_main(capsys, argv)
    assert code == 2 and err.count("\n") == 1 and "does not exist" in err


def test_subprocess_exit_codes_and_stderr():
    ok = run_subprocess([*ANALYZE, "--json"])
    assert ok.returncode == 0, ok.stderr
    assert json.loads(ok.stdout)["walks"] is True
    for argv in (["analyze", "--beta", "2", "--theta-ii", "0", "--phi0", "45"], ["--nope"], []):
        bad = run_subprocess(argv)
        assert bad.returncode == 2
        assert bad.stdout == ""
        assert len(bad.stderr.splitlines()) == 1 and "Traceback" not in bad.stderr
    help_ = run_subprocess(["--help"])
    assert help_.returncode == 0 and "analyze" in help_.stdout


def test_simulate_json_contract(capsys, tmp_path):
    pytest.importorskip("vsw.models.ile.simulate")
    plot = tmp_path / "sim.png"
    argv = ["simulate", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45", "--q0", "0.3"]
    code, out, err = run_main(capsys, [*argv, "--steps", "6", "--json", "--plot", str(plot)])
    assert code == 0, err
    assert err == ""  # no progress bar when stderr is not a terminal
    data = json.loads(out)
    assert data["ended"] == "completed"
    assert len(data["q"]) == 7 and data["q"][0] == 0.3
    # Linear map (9): q_n - q^f = lambda^n (q0 - q^f), lambda from eq. (19).
    beta, phi0 = 0.8, math.radians(45)
    lam = beta**2 * math.cos(phi0) ** 2
    q_fixed = data["q_fixed_closed_form"]
    expected = q_fixed + lam ** np.arange(7) * (0.3 - q_fixed)
    np.testing.assert_allclose(data["q"], expected, rtol=1e-8)
    assert plot.stat().st_size > 0
    code, out, _ = run_main(capsys, [*argv[:-1], "0.001", "--steps", "3", "--json"])
    assert code == 0 and json.loads(out)["ended"] == "fell-backward"
    code, out, _ = run_main(capsys, [*argv[:-1], "1.2", "--steps", "3", "--json"])
    assert code == 0 and json.loads(out)["ended"] == "lift-off"


def test_basin_json_contract(capsys, tmp_path):
    argv = ["basin", "--beta", "0.8", "--phi0", "45", "--theta-step", "5", "--n-q", "201"]
    code, out, err = run_main(capsys, [*argv, "--json", "--plot", str(tmp_path / "b.svg")])
    assert code == 0, err
    data = json.loads(out)
    assert len(data["theta_II"]) == len(data["q_min"]) == len(data["q_max"]) == 15
    assert data["theta_II"][0] == pytest.approx(math.radians(-30))
    assert data["q_min"][0] is None  # theta_II = -30 deg < theta_I: never extends
    i0 = data["theta_II_deg"].index(0.0)
    theta_I = -math.atan((0.8 - math.cos(math.radians(45))) / math.sin(math.radians(45)))
    assert data["q_min"][i0] == pytest.approx(2 * (1 - math.cos(theta_I)) / 0.8, rel=1e-9)  # (14)
    assert (tmp_path / "b.svg").stat().st_size > 0


def test_basin_edge_checks(capsys):
    pytest.importorskip("vsw.models.ile.simulate")
    argv = ["basin", "--beta", "0.8", "--phi0", "45", "--theta-step", "10", "--n-q", "101"]
    code, out, _ = run_main(capsys, [*argv, "--check-edges", "2", "--json"])
    assert code == 0
    checks = json.loads(out)["edge_checks"]
    assert checks and all(c["ok"] for c in checks)


def test_progress_bar_only_on_a_terminal():
    import io

    from vsw.runtime.progress import ProgressBar

    quiet = io.StringIO()
    bar = ProgressBar("x", stream=quiet)
    bar(1, 2)
    bar(2, 2)
    assert quiet.getvalue() == ""

    class Tty(io.StringIO):
        def isatty(self):
            return True

    loud = Tty()
    bar = ProgressBar("x", stream=loud, min_interval=0)
    bar(1, 2)
    bar(2, 2)
    assert "[" in loud.getvalue() and loud.getvalue().endswith("2/2\n")


def test_commands_are_registered_by_name_and_a_run_imports_only_its_own():
    """COMMANDS names each command as its module registers it; a command line naming a
    command builds that command's parser alone (``vsw --help`` all of them), and a grid
    basin imports no other command's module, none of the ILE's closed forms, no SciPy."""
    import argparse

    import vsw.cli.app as app

    def choices(parser):
        return list(next(a for a in parser._actions
                         if isinstance(a, argparse._SubParsersAction)).choices)  # fmt: skip

    for name in app.COMMANDS:
        assert choices(app.build_parser(name)) == [name]
    assert choices(app.build_parser()) == choices(app.build_parser("no-such")) == [*app.COMMANDS]
    code = (
        "import sys\nfrom vsw.cli import main\n"
        "main(['basin', '--model', 'rimless-wheel', '--grid', 'theta_dot=0.5:3:5',"
        " '--steps', '5'])\n"
        "print(' '.join(sorted(sys.modules)))"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    imported = set(run.stdout.splitlines()[-1].split())
    others = {m for n, m in app.COMMANDS.items() if n != "basin"}
    assert "vsw.cli.basin" in imported and not imported & others
    assert not {m for m in imported if m.startswith(("vsw.models.ile", "vsw.cli.ile_basin",
                                                     "scipy", "matplotlib"))}  # fmt: skip


def test_a_command_module_registers_and_gets_the_parser_rules(monkeypatch, capsys):
    """A command is a module with ``register`` and ``run``: its parser is the CLI's
    (one-line usage errors)."""
    import types

    import vsw.cli.app as app

    fake = types.ModuleType("vsw.cli.fake_cmd")

    def register(subparsers):
        p = subparsers.add_parser("hello")
        p.add_argument("--n", type=int, required=True)
        p.set_defaults(func=fake.run)

    fake.register = register
    fake.run = lambda args: print("hi", args.n) or 0
    monkeypatch.setitem(sys.modules, fake.__name__, fake)
    monkeypatch.setattr(app, "COMMANDS", {**app.COMMANDS, "hello": fake.__name__})
    assert main(["hello", "--n", "3"]) == 0
    assert capsys.readouterr().out == "hi 3\n"
    assert main(["hello", "--n", "x"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_every_json_output_starts_with_the_envelope(capsys, tmp_path):
    """model, parameters, units, provenance first, for every command and model."""
    commands = [
        ANALYZE,
        ["analyze", "--model", "rimless-wheel"],
        ["simulate", "--steps", "1"],
        ["simulate", "--model", "rimless-wheel", "--steps", "1"],
        ["basin", "--theta-step", "10", "--n-q", "51"],
        ["basin", "--model", "rimless-wheel", "--grid", "theta_dot=0.5:3:5", "--steps", "5"],
        ["sweep", "--over", "theta_II=0:0.1:2"],
        ["sweep", "--model", "rimless-wheel", "--over", "gamma=0.1:0.12:2"],
        ["animate", "--model", "rimless-wheel", "--steps", "1", "--out", str(tmp_path / "a.svg")],
        ["design", "--stepper-2d", "--target-speed", "0.8"],
        ["explore", "--out", str(tmp_path / "page.html")],
        ["rough", "--model", "rimless-wheel", "--sigma", "0.01", "--walks", "5", "--max-steps",
         "10"],
    ]  # fmt: skip
    for argv in commands:
        code, out, err = run_main(capsys, [*argv, "--json"])
        assert code == 0, (argv, err)
        data = json.loads(out)
        assert list(data)[:4] == ["model", "parameters", "units", "provenance"], argv
        provenance = data["provenance"]
        assert provenance["command"] == "vsw " + " ".join([*argv, "--json"])
        assert provenance["vsw"] and "tolerances" in provenance
        assert data["units"]["angle"] == "rad"


def test_help_shows_each_default_once_and_marks_the_required(capsys):
    commands = ("analyze", "simulate", "basin", "sweep", "animate", "design", "explore", "rough")
    for command in commands:
        assert main([command, "--help"]) == 0
        text = " ".join(capsys.readouterr().out.split())
        assert text.count("(default: 10) (default: 10)") == 0
        assert "(default: None)" not in text
        for default in set(__import__("re").findall(r"\(default: [^)]*\)", text)):
            assert text.count(default + " " + default) == 0, (command, default)
    main(["sweep", "--help"])
    assert "(required)" in capsys.readouterr().out
    main(["simulate", "--help"])
    assert "(default: 10)" in capsys.readouterr().out
