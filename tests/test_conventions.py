"""One convention in every command: whole option names, the environment the help lists,
one name for a start state, one meaning of a plain number, one unit per quantity, and a
unit for every number of the JSON output."""

from __future__ import annotations

import argparse
import json
import math
import re
from pathlib import Path

import pytest

import vsw
from vsw.cli import main
from vsw.cli.app import COMMANDS, build_parser


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_every_parser_refuses_abbreviations():
    parser = build_parser()
    assert parser.allow_abbrev is False
    for name, sub in _subparsers(parser).items():
        assert sub.allow_abbrev is False, name


@pytest.mark.parametrize(
    "argv",
    [
        ["analyze", "--bet", "0.8"],
        ["simulate", "--stat", "x=1"],
        ["design", "--maximize", "speed", "--fi", "beta=0.8"],
        ["basin", "--mod", "ile"],
    ],
)
def test_an_abbreviated_option_is_a_one_line_usage_error(capsys, argv):
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert len(err.strip().splitlines()) == 1
    assert "unrecognized arguments" in err and argv[-2] in err


def test_every_command_is_checked():
    assert set(_subparsers(build_parser())) == set(COMMANDS)


# --- the environment: every VSW_* variable the package reads is in `vsw --help` -------------

_ENVIRON_READ = re.compile(r"""(?:environ(?:\.get)?\s*[\[(]|getenv\s*\()\s*["'](VSW_[A-Z_]+)["']""")


def _variables_read() -> set[str]:
    root = Path(vsw.__file__).parent
    found: set[str] = set()
    for path in root.rglob("*.py"):
        found |= set(_ENVIRON_READ.findall(path.read_text(encoding="utf-8")))
    return found


def test_the_scan_finds_the_variables_it_should():
    # The scan itself must work: these are read with os.environ.get in vsw/.
    assert {"VSW_THREADS", "VSW_CACHE_DIR", "VSW_MODELS_DIR", "VSW_SEARCH_CACHE"} <= (
        _variables_read()
    )


def test_every_variable_read_is_in_the_help(capsys):
    assert main(["--help"]) == 0
    text = capsys.readouterr().out
    environment = text.split("environment:", 1)[1]
    listed = set(re.findall(r"^  (VSW_[A-Z_]+) ", environment, flags=re.MULTILINE))
    assert _variables_read() <= listed, sorted(_variables_read() - listed)


def test_the_cache_directory_is_described_by_everything_it_holds(capsys):
    assert main(["--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    cache = text.split("VSW_CACHE_DIR ", 1)[1].split(" VSW_", 1)[0]
    for held in ("kernels", "model files", "searches"):
        assert held in cache, held


# --- a start state is --state in every command ------------------------------------------------


def test_a_start_state_is_named_state_in_every_command():
    named = {}
    for name, sub in _subparsers(build_parser()).items():
        strings = {s for a in sub._actions for s in a.option_strings if "state" in s}
        if strings:
            named[name] = strings
    assert set(named) >= {"simulate", "animate", "sweep", "continue"}
    for name, strings in named.items():
        assert strings == {"--state"}, (name, strings)


def test_continue_refuses_from_state(capsys):
    argv = ["continue", "--model", "compass-gait", "--over", "gamma=0.01:0.02"]
    assert main([*argv, "--from-state", "theta=0.1"]) == 2
    err = capsys.readouterr().err
    assert "unrecognized arguments: --from-state" in err


# --- a plain number is in the parameter table's unit, in design --fix too ---------------------


def _design(capsys, *argv: str) -> dict:
    assert main(["design", "--maximize", "speed", "--fix", "beta=0.8", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_ile_design_fix_takes_radians_or_degrees_with_deg(capsys):
    in_degrees = _design(capsys, "--fix", "theta_II=5deg")
    in_radians = _design(capsys, "--fix", "theta_II=0.0872664626")  # 5 deg
    assert in_degrees["parameters"]["theta_II"] == pytest.approx(math.radians(5), abs=1e-10)
    for name in ("beta", "theta_II", "phi0"):
        assert in_radians["parameters"][name] == pytest.approx(
            in_degrees["parameters"][name], abs=1e-9
        )
    assert in_radians["speed"] == pytest.approx(in_degrees["speed"], rel=1e-9)


def test_ile_design_fix_of_5_is_5_rad_and_refused(capsys):
    assert main(["design", "--maximize", "speed", "--fix", "theta_II=5"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1
    assert "--fix theta_II=5" in err and "(-1.5708, 1.5708) rad" in err


def test_ile_named_angle_bounds_are_degrees_as_their_help_says(capsys):
    named = _design(capsys, "--theta-ii-max", "5")
    bound = _design(capsys, "--bound", "theta_II=:5deg")
    assert named["parameters"] == bound["parameters"]
    assert named["parameters"]["theta_II"] <= math.radians(5) + 1e-12
    assert main(["design", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "theta_II <= this [deg]" in text


# --- one unit per quantity: a step frequency is Hz in SI, 1/time unit in scaled units --------


def test_step_frequency_is_hz_in_si_for_every_model(capsys):
    si = ["design", "--maximize", "speed", "--fix", "beta=0.8", "--leg-length", "1"]
    assert main(si) == 0
    ile = {line.split()[0]: line.split()[-1] for line in capsys.readouterr().out.splitlines()}
    assert ile["step_frequency"] == "Hz" and ile["step_period_s"] == "s"
    gait = ["design", "--model", "compass-gait", "--minimize", "eigenvalue", "--starts", "1"]
    assert main(gait) == 0
    text = capsys.readouterr().out
    (line,) = [row for row in text.splitlines() if row.strip().startswith("step_frequency")]
    assert line.split()[-1] == "Hz"
    assert main([*gait, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["units"]["time"] == "s"
    assert data["units"]["quantities"]["step_frequency"] == "Hz"


@pytest.mark.slow  # compiles the simplest walker's simulator first: about 15 s
def test_step_frequency_in_scaled_units_is_one_over_the_time_unit(capsys):
    argv = ["design", "--model", "simplest-walker", "--minimize", "eigenvalue", "--starts", "1"]
    assert main([*argv, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["units"]["time"] == "sqrt(l/g)"
    assert data["units"]["quantities"]["step_frequency"] == "1/sqrt(l/g)"


# --- an angle given in degrees is echoed in degrees; the JSON stays in rad ---------------------


def _rows(text: str, name: str) -> list[list[str]]:
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.split()[:1] == [name])
    return [line.split() for line in lines[start + 1 :] if line.strip()]


def test_ile_sweep_echoes_degrees_and_keeps_radians_in_json(capsys):
    argv = ["sweep", "--over", "theta_II=-10deg:10deg:3", "--param", "phi0=40deg"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    header = text.splitlines()[0]
    assert "over theta_II deg" in header and "phi0 = 40 deg" in header
    assert [float(row[0]) for row in _rows(text, "theta_II")] == [-10.0, 0.0, 10.0]
    assert main([*argv, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["over_unit"] == "rad" and data["units"]["angle"] == "rad"
    values = [p["theta_II"] for p in data["points"]]
    assert values == pytest.approx([math.radians(-10), 0.0, math.radians(10)], abs=1e-15)


def test_ile_sweep_in_radians_is_shown_in_radians(capsys):
    assert main(["sweep", "--over", "theta_II=-0.1:0.1:3"]) == 0
    text = capsys.readouterr().out
    assert "over theta_II rad" in text.splitlines()[0]
    assert [float(row[0]) for row in _rows(text, "theta_II")] == [-0.1, 0.0, 0.1]


def test_sweep_of_a_model_echoes_degrees(capsys):
    argv = ["sweep", "--model", "rimless-wheel", "--over", "gamma=4deg:5deg:2"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "over gamma deg" in text.splitlines()[0]
    assert [float(row[0]) for row in _rows(text, "gamma")] == [4.0, 5.0]


def test_continue_echoes_degrees_and_keeps_radians_in_json(capsys):
    argv = ["continue", "--model", "rimless-wheel", "--over", "gamma=4deg:5deg"]
    argv += ["--max-points", "5"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "gamma deg from 4 to 5" in text
    branch = next(line for line in text.splitlines() if "branch" in line)
    assert "gamma 4 to " in branch
    assert main([*argv, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["over_unit"] == "rad"
    assert data["range"] == pytest.approx([math.radians(4), math.radians(5)], rel=1e-15)


# --- optimize names its units -----------------------------------------------------------------

OPTIMIZE = ["optimize", "--model", "point-mass-biped", "--target-speed", "0.5", "--nodes", "5"]


def test_optimize_text_names_every_unit(capsys):
    main(OPTIMIZE)  # a coarse mesh may end not-converged (exit 3): the report is printed
    text = capsys.readouterr().out
    lines = {line.split()[0]: line for line in text.splitlines()}
    # The point-mass biped is in SI; its inputs a force (N) and a torque (N m).
    assert "N^2 s + (N m)^2 s (Hermite-Simpson" in lines["minimized"]
    assert re.search(r"period +\S+ s; step length \S+ m; speed \S+ m/s$", lines["period"])
    for pattern in (
        r"^work of stance\.leg_force +\S+ / \S+ J$",
        r"^impulse heelstrike\.push_off +\S+ N s$",
        r"^impulse heelstrike\.torque_impulse +\S+ N m s$",
        r"^ground at heelstrike\.new_foot +normal \S+, tangential \S+ N s$",
    ):
        assert re.search(pattern, text, flags=re.MULTILINE), pattern


def test_optimize_json_names_the_cost_unit_by_the_cost(capsys):
    main([*OPTIMIZE, "--minimize", "work", "--json"])
    data = json.loads(capsys.readouterr().out)
    quantities = data["units"]["quantities"]
    assert quantities["cost"] == "J" and quantities["work"] == "J"
    assert quantities["impulses.heelstrike.torque_impulse"] == "N m s"
    assert quantities["period"] == "s" and quantities["speed"] == "m/s"


# --- every number of every command's JSON has a unit ------------------------------------------


def unlabelled(data: dict) -> list[str]:
    """The paths of the numbers of a JSON output without a unit by the envelope's rule: the
    ``unit`` of the object a number is in, else the innermost key on its path named in
    ``units.quantities`` as PARENT.KEY or KEY, and under ``parameters`` the parameter's."""
    units = data["units"]
    named = units.get("quantities", {})
    missing: set[str] = set()

    def walk(value: object, path: list[str], parent: str, unit: str | None) -> None:
        if isinstance(value, dict):
            # An object's own unit may be '' (a dimensionless margin among conditions).
            own = value.get("unit") if isinstance(value.get("unit"), str) else None
            for key, item in value.items():
                inner = (
                    (own or "1")
                    if own is not None
                    else named.get(f"{parent}.{key}", named.get(key, unit))
                )
                walk(item, [*path, key], key, inner)
        elif isinstance(value, list):
            for item in value:
                walk(item, [*path, "[]"], parent, unit)
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            if unit is None or not isinstance(unit, str) or not unit:
                missing.add(".".join(path))

    for key, value in data.items():
        if key in ("units", "provenance"):
            continue
        if key == "parameters" and isinstance(value, dict):
            missing |= {f"parameters.{n}" for n in value if n not in units["parameters"]}
            continue
        walk(value, [key], key, named.get(key))
    return sorted(missing)


def test_the_unit_check_finds_a_number_without_a_unit():
    data = {"units": {"parameters": {}, "quantities": {"period": "s"}}, "period": 1.0,
            "x": {"period": 2.0, "other": 3}, "y": [{"unit": "m", "margin": 1}]}  # fmt: skip
    assert unlabelled(data) == ["x.other"]


RUNS = [
    ["analyze"],
    ["analyze", "--model", "compass-gait"],
    ["analyze", "--model", "point-mass-biped"],
    ["simulate", "--steps", "2"],
    ["simulate", "--model", "rimless-wheel", "--steps", "2"],
    ["sweep", "--over", "theta_II=-10deg:10deg:3"],
    ["sweep", "--model", "rimless-wheel", "--over", "gamma=4deg:5deg:2"],
    ["sweep", "--model", "rimless-wheel", "--over", "gamma=4deg:5deg:2", "--brute-force"],
    ["continue", "--model", "rimless-wheel", "--over", "gamma=4deg:5deg", "--max-points", "5",
     "--free", "alpha=0.3:0.5"],
    ["design", "--maximize", "speed", "--minimize", "cost-of-transport"],
    ["design", "--maximize", "speed", "--leg-length", "1"],
    ["design", "--target-speed", "0.8", "--stepper-2d"],
    OPTIMIZE,
    ["basin", "--n-q", "5", "--theta-step", "20"],
    ["basin", "--model", "rimless-wheel", "--grid", "theta_dot=0.5:2:5", "--steps", "5"],
    ["hzd", "--model", "three-link-biped", "--constraints",
     str(Path(__file__).resolve().parent.parent / "examples/hzd/three_link_mirror.py")],
]  # fmt: skip
SLOW_RUNS = [
    ["analyze", "--model", "vsw-biped"],
    ["design", "--model", "compass-gait", "--minimize", "eigenvalue", "--starts", "1"],
    ["optimize", "--model", "compass-gait", "--target-speed", "0.8", "--minimize", "work",
     "--verify", "--nodes", "5", "--starts", "2", "--limit", "hip_torque=-20:20"],
]  # fmt: skip
"""The cheapest runs of every command with --json, on models of each unit system; the
slow tier adds a scaled biped's search, a design on the periodic orbit (compiled first) and
an optimisation from several starts, verified."""


def _json(capsys, argv: list[str]) -> dict:
    code = main([*argv, "--json"])
    out, err = capsys.readouterr()
    assert code in (0, 3), err  # 3: a coarse optimisation may end not-converged
    return json.loads(out)


@pytest.mark.parametrize("argv", RUNS, ids=[" ".join(a) for a in RUNS])
def test_every_number_of_the_json_has_a_unit(capsys, argv):
    data = _json(capsys, argv)
    assert list(data)[:4] == ["model", "parameters", "units", "provenance"]
    assert unlabelled(data) == []


FILE_RUNS = [
    ["animate", "--model", "rimless-wheel", "--steps", "1", "--out", "{tmp}/a.svg"],
    ["animate", "--steps", "1", "--out", "{tmp}/b.gif"],
    ["explore", "--model", "compass-gait", "--out", "{tmp}/e.html"],
    ["explore", "--out", "{tmp}/ile.html"],
    ["simulate", "--model", "compass-gait", "--steps", "1", "--trajectory", "{tmp}/t.csv"],
    ["rough", "--model", "simplest-walker", "--sigma", "0.001", "--walks", "20", "--max-steps",
     "30"],
]  # fmt: skip
"""The commands that write a file (and rough ground's few walks), each model's unit system."""


def test_every_command_with_json_is_run_by_a_unit_check():
    run = {argv[0] for argv in (*RUNS, *SLOW_RUNS, *FILE_RUNS)}
    assert set(_subparsers(build_parser())) - {"models"} <= run


@pytest.mark.parametrize("argv", FILE_RUNS, ids=[" ".join(a[:3]) for a in FILE_RUNS])
def test_every_number_of_the_file_writers_json_has_a_unit(capsys, tmp_path, argv):
    data = _json(capsys, [a.format(tmp=tmp_path) for a in argv])
    assert list(data)[:4] == ["model", "parameters", "units", "provenance"]
    assert unlabelled(data) == []


@pytest.mark.slow
@pytest.mark.parametrize("argv", SLOW_RUNS, ids=[" ".join(a) for a in SLOW_RUNS])
def test_every_number_of_the_slow_runs_json_has_a_unit(capsys, argv):
    assert unlabelled(_json(capsys, argv)) == []
