"""A model of the user's own, outside the package: ``--model path/to/model.py``.

The model file below is written here as a user would write it (the engine's language, no
``derive()``): a wheel with spokes, declared from scratch. Its numbers are checked against
the rimless wheel's closed form (Drake's ``examples/rimless_wheel``; McGeer 1990), which
the engine never sees, end to end through the command line in fresh processes: derive
(on the first command), analyze, simulate, basin; then the cache (no second derivation;
an edited file derived anew) and the one-line refusals.
"""

from __future__ import annotations

import importlib.metadata
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vsw import models
from vsw.models import user
from vsw.runtime.errors import VswInputError

ROOT = Path(__file__).resolve().parent.parent

MODEL_FILE = '''
"""Spoked wheel: a hub mass on massless spokes, 2 alpha apart, rolling down a slope."""
import sympy as sm

from derive.engine.model import (
    NORMAL_FORCE, Coordinate, Event, Failure, Impact, Model, Parameter, Phase, PointMass, leg,
)

PARAMETERS = (
    Parameter("alpha", "alpha", 0.0, 1.5707963267948966, "0 < alpha < pi/2", "half spoke angle",
              {"positive": True}, default=0.39269908169872414, unit="rad"),
    Parameter("gamma", "gamma", -1.5, 1.5, "slope", "slope angle", default=SLOPE, unit="rad"),
    Parameter("l", "l", 0.0, float("inf"), "l > 0", "spoke length", {"positive": True},
              default=1.0, unit="m"),
    Parameter("g", "g", 0.0, float("inf"), "g > 0", "gravity", {"positive": True},
              default=9.81, unit="m/s^2"),
)
alpha, gamma, l, g = (p.symbol for p in PARAMETERS)
ANGLE = Coordinate("theta", "stance spoke angle", "rad", reference="the slope normal",
                   positive="downhill")
theta = ANGLE.q
ROLLING = Phase(
    "rolling",
    coordinates=(ANGLE,),
    bodies=(PointMass("hub", 1, leg(theta, l)),),
    gravity=(g * sm.sin(gamma), -g * sm.cos(gamma)),
    points={"next_foot": tuple(h - f for h, f in zip(leg(theta, l), leg(theta - 2 * alpha, l)))},
)
MODEL = Model(
    name="spoked_wheel",
    title="Spoked wheel",
    description="a user's rimless wheel",
    source="a user's model file",
    parameters=PARAMETERS,
    phases=(ROLLING,),
    events=(Event("touchdown", "rolling", "rolling", guard=ROLLING.points["next_foot"][1],
                  direction=-1, reset=Impact("next_foot", {theta: theta - 2 * alpha}), at=alpha,
                  ends_step=True),),
    failures=(Failure("rolled-back", ANGLE.u, -1, "the wheel rolls back"),
              Failure("lift-off", NORMAL_FORCE, -1, "the foot leaves the slope")),
    units={"time": "s", "length": "m", "mass": "kg", "energy": "J/kg", "force": "N/kg"},
    step_length=2 * l * sm.sin(alpha),
    section={"theta": -alpha},
    search={"theta_dot": (0.0, 12.0)},
)
UNITS = "Angles in radians, lengths in m, time in s."
'''


def omega_fixed(gamma: float, alpha: float = math.pi / 8, leg: float = 1.0, g: float = 9.81):
    """Drake's closed form of the rate just after the collision on the period-one gait."""
    return 1 / math.tan(2 * alpha) * math.sqrt(4 * g / leg * math.sin(alpha) * math.sin(gamma))


def write_model(directory: Path, slope: float) -> Path:
    path = directory / "spoked_wheel.py"
    path.write_text(MODEL_FILE.replace("SLOPE", repr(slope)))
    return path


def vsw(*argv: str, cache: Path) -> subprocess.CompletedProcess:
    env_code = "import sys; from vsw.cli import main; sys.exit(main(sys.argv[1:]))"
    env = {**os.environ, "VSW_MODELS_DIR": str(cache)}
    return subprocess.run([sys.executable, "-c", env_code, *argv], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600)  # fmt: skip


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """The user's repository (a model file) and the directory they name for its code."""
    base = tmp_path_factory.mktemp("users_repo")
    return write_model(base, 0.08), base / "generated_models"


def test_a_model_file_end_to_end(workspace):
    path, cache = workspace
    analyzed = vsw("analyze", "--model", str(path), "--json", cache=cache)
    assert analyzed.returncode == 0, analyzed.stderr
    # The first command derives it, and says so in one line once done.
    (line,) = analyzed.stderr.strip().splitlines()
    assert line.startswith(f"vsw: deriving the model of {path}") and " done in " in line
    data = json.loads(analyzed.stdout)
    assert data["model"] == "spoked-wheel"
    (gait,) = data["fixed_points"]
    assert gait["state"]["theta_dot"] == pytest.approx(omega_fixed(0.08), rel=1e-9)
    assert gait["max_abs_eigenvalue"] == pytest.approx(math.cos(2 * math.pi / 8) ** 2, rel=1e-6)
    # Generated into the named directory, under a key of the file's content.
    (package,) = [p.parent for p in cache.glob("*/*/__init__.py")]
    assert package.name == "spoked_wheel" and package.parent.name.startswith("spoked_wheel-")

    described = vsw("models", "--model", str(path), "--json", cache=cache)
    assert described.returncode == 0, described.stderr
    (table,) = json.loads(described.stdout)["models"]
    assert [p["name"] for p in table["parameters"]] == ["alpha", "gamma", "l", "g"]

    walked = vsw("simulate", "--model", str(path), "--steps", "6", "--json", cache=cache)
    assert walked.returncode == 0, walked.stderr
    assert "deriving" not in walked.stderr  # cached: derived once
    steps = json.loads(walked.stdout)
    last = steps["section_states"][-1]
    assert last["theta_dot"] == pytest.approx(omega_fixed(0.08), rel=1e-6)

    grid = ["--grid", "theta_dot=0.2:3:8", "--steps", "40"]
    basin = vsw("basin", "--model", str(path), *grid, "--json", cache=cache)
    assert basin.returncode == 0, basin.stderr
    cells = json.loads(basin.stdout)
    assert {"converged", "fell"} <= set(cells["outcome"][0])
    # The built-in rimless wheel is the same physics: the same cells, the same steps.
    reference = vsw("basin", "--model", "rimless-wheel", *grid, "--json", cache=cache)
    same = json.loads(reference.stdout)
    assert cells["outcome"] == same["outcome"] and cells["steps"] == same["steps"]
    renamed = {"rolled-back": "fell-backward"}  # the user named that failure differently
    assert [[renamed.get(e, e) for e in row] for row in cells["ended"]] == same["ended"]


def test_an_edited_model_file_is_derived_anew(tmp_path):
    path, cache = write_model(tmp_path, 0.08), tmp_path / "models"
    first = vsw("analyze", "--model", str(path), "--json", cache=cache)
    assert first.returncode == 0, first.stderr
    write_model(tmp_path, 0.12)  # a steeper default slope
    second = vsw("analyze", "--model", str(path), "--json", cache=cache)
    assert second.returncode == 0, second.stderr
    assert "deriving the model of" in second.stderr
    (gait,) = json.loads(second.stdout)["fixed_points"]
    assert gait["state"]["theta_dot"] == pytest.approx(omega_fixed(0.12), rel=1e-9)
    assert len([p for p in cache.glob("spoked_wheel-*") if p.is_dir()]) == 2


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "does not exist"),
        ("x = 1\n", "defines neither derive() nor MODEL"),
        ("raise ValueError('no such slope')\n", "ValueError: no such slope"),
        ("raise SystemExit(3)\n", "exited (3)"),
    ],
)
def test_a_bad_model_file_is_refused_in_one_line(tmp_path, content, message):
    """One line: the error alone (the note that the model is being derived is written
    only once the derivation is done, or erased on a terminal)."""
    path = tmp_path / "walker.py"
    if content is not None:
        path.write_text(content)
    done = vsw("analyze", "--model", str(path), cache=tmp_path / "models")
    assert done.returncode == 2
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("vsw") and message in line and "Traceback" not in done.stderr


def test_an_installed_packages_entry_point_names_a_model_file(tmp_path, monkeypatch):
    """``[project.entry-points."vsw.models"] kneed = "my_walkers.kneed"`` in a package."""
    package = tmp_path / "my_walkers"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "kneed.py").write_text("raise ImportError('not imported to be found')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    point = importlib.metadata.EntryPoint("kneed", "my_walkers.kneed", user.ENTRY_POINT_GROUP)
    monkeypatch.setattr(
        importlib.metadata,
        "entry_points",
        lambda group: [point] if group == user.ENTRY_POINT_GROUP else [],
    )
    assert models.key("kneed") == str((package / "kneed.py").resolve())
    with pytest.raises(VswInputError, match="nor a model file"):
        models.key("knee")


def test_derive_file_never_replaces_a_directory_it_did_not_write(tmp_path):
    """``--out`` is replaced whole: a directory of the user's (with their model in it) is
    refused, an earlier output is replaced."""
    path = write_model(tmp_path, 0.08)
    command = [sys.executable, "-m", "derive", "--file", str(path)]
    refused = subprocess.run([*command, "--out", str(tmp_path)], cwd=ROOT, capture_output=True,
                             text=True)  # fmt: skip
    assert refused.returncode == 2 and "holds no earlier output" in refused.stderr
    assert path.is_file()
    out = tmp_path / "out"
    for _ in range(2):  # the second run replaces the first's output
        done = subprocess.run([*command, "--out", str(out)], cwd=ROOT, capture_output=True,
                              text=True)  # fmt: skip
        assert done.returncode == 0, done.stderr
    assert (out / "spoked_wheel" / "__init__.py").is_file()


def test_a_cached_package_anyone_may_write_is_not_loaded(tmp_path):
    path, cache = write_model(tmp_path, 0.08), tmp_path / "models"
    assert vsw("models", "--model", str(path), cache=cache).returncode == 0
    (init,) = cache.glob("*/spoked_wheel/__init__.py")
    init.chmod(init.stat().st_mode | 0o002)
    done = vsw("models", "--model", str(path), cache=cache)
    assert done.returncode == 2
    assert "writable by anyone: not loaded" in done.stderr.strip().splitlines()[-1]
