"""The command line's models: ``vsw models``, ``--model``, ``--param`` and ``vsw sweep``.

The rimless wheel's numbers are checked against closed forms derived here by hand from its
energy integral and the collision's angular momentum balance (McGeer 1990; the fixed point
is the one of Drake's ``examples/rimless_wheel`` test), not against the engine.
"""

from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from vsw.cli import main

pytest.importorskip("casadi")

ALPHA, GAMMA, LEG, G = math.pi / 8, 0.08, 1.0, 9.81  # Drake's rimless wheel test
RIMLESS = ["--model", "rimless-wheel"]
PARAMS = [f"--param=alpha={ALPHA!r}", "--param=gamma=0.08", "--param=l=1", "--param=g=9.81"]


def run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def run_json(capsys, argv):
    code, out, err = run(capsys, [*argv, "--json"])
    assert code == 0 and err == "", err
    return json.loads(out)


def payload(data):
    """A command's JSON without its provenance (which names the command line)."""
    return {k: v for k, v in data.items() if k != "provenance"}


def omega_fixed(alpha=ALPHA, gamma=GAMMA, leg=LEG, g=G) -> float:
    """Drake's closed form of the rate just after the collision on the period-one gait."""
    return 1 / math.tan(2 * alpha) * math.sqrt(4 * g / leg * math.sin(alpha) * math.sin(gamma))


def omega_before_collision_sq(omega0, alpha=ALPHA, gamma=GAMMA, leg=LEG, g=G) -> float:
    """Energy from theta = -alpha to alpha: w^2 l^2 / 2 + g l cos(gamma + theta) constant."""
    return omega0**2 + 2 * g / leg * (math.cos(gamma - alpha) - math.cos(gamma + alpha))


def apex_bound_sq(alpha=ALPHA, gamma=GAMMA, leg=LEG, g=G) -> float:
    """The rate squared just after the collision below which the wheel rolls back."""
    return 2 * g / leg * (1 - math.cos(alpha - gamma))


def lift_off_bound_sq(alpha=ALPHA, gamma=GAMMA, leg=LEG, g=G) -> float:
    """Above it the spoke pulls before the next collision: the spoke force per mass
    g cos(gamma + theta) - l w^2 is least at theta = alpha."""
    return g / leg * (3 * math.cos(gamma + alpha) - 2 * math.cos(gamma - alpha))


# --- vsw models ------------------------------------------------------------------------------


def test_models_json_lists_every_generated_table(capsys):
    import importlib

    import generated

    listing = run_json(capsys, ["models"])
    assert listing["provenance"]["command"] == "vsw models --json"
    models = listing["models"]
    assert [m["name"] for m in models] == [k.replace("_", "-") for k in generated.MODELS]
    for model, key in zip(models, generated.MODELS):
        assert {"name", "description", "parameters", "units", "state", "section"} <= model.keys()
        assert model["description"] and model["units"]
        table = importlib.import_module(f"generated.{key}.params").PARAMETERS
        assert [p["name"] for p in model["parameters"]] == [p.name for p in table]
        for row, p in zip(model["parameters"], table):
            assert set(row) >= {"name", "default", "unit", "lower", "upper", "meaning"}
            assert row["default"] == p.default and row["unit"] == p.unit
            assert row["meaning"] == p.description
            for bound, value in (("lower", p.lower), ("upper", p.upper)):
                assert (math.inf if row[bound] is None and value > 0 else row[bound]) == value
    by_name = {m["name"]: m for m in models}
    rimless = {p["name"]: p for p in by_name["rimless-wheel"]["parameters"]}
    assert rimless["l"]["upper"] is None and rimless["l"]["unit"] == "m"  # no upper bound
    assert rimless["alpha"]["default"] == pytest.approx(math.pi / 8, rel=1e-15)
    state = by_name["rimless-wheel"]["state"]
    assert [s["name"] for s in state] == ["theta", "theta_dot"]
    assert state[0]["reference"] == "the slope normal" and state[0]["rate"] == "theta_dot"
    assert "downhill" in state[0]["positive"] and state[1]["unit"] == "rad/s"


def test_every_model_states_its_convention(capsys):
    """Rates are <coordinate>_dot everywhere; every coordinate says what it is, where it is
    zero and what its sign means; the section names its free components and search box."""
    for m in run_json(capsys, ["models"])["models"]:
        coordinates = [s for s in m["state"] if s["kind"] == "coordinate"]
        rates = [s for s in m["state"] if s["kind"] == "rate"]
        assert [s["name"] for s in rates] == [c["name"] + "_dot" for c in coordinates]
        for c in coordinates:
            assert c["meaning"] and c["reference"] and c["positive"]
            assert c["unit"] in ("rad", m["units"]["length"]), (m["name"], c["name"])
        section = m["section"]
        names = [s["name"] for s in m["state"]]
        assert sorted(section["free"] + section["determined"]) == sorted(names), m["name"]
        assert list(section["search_box"]) == section["free"]
        assert {"time", "length", "force"} <= set(m["units"]), m["name"]
        for f in m["failures"]:
            assert f["unit"] and f["meaning"], (m["name"], f)


def test_models_title_and_units_are_the_derivations(capsys):
    import importlib

    from derive.models import MODELS

    models = {m["name"]: m for m in run_json(capsys, ["models"])["models"]}
    for key in MODELS:
        spec = importlib.import_module(f"generated.{key}").HYBRID
        assert models[key.replace("_", "-")]["title"] == spec["title"]
        units = models[key.replace("_", "-")]["units"]
        assert {k: v for k, v in units.items() if k != "rate"} == spec["units"]


def test_models_text(capsys):
    code, out, err = run(capsys, ["models"])
    assert code == 0 and err == ""
    assert "rimless-wheel: " in out and "ile: " in out and "m/s^2" in out


# --- the rimless wheel -----------------------------------------------------------------------


def test_rimless_wheel_gait_is_drakes_closed_form(capsys):
    from scipy.integrate import quad

    data = run_json(capsys, ["analyze", *RIMLESS, *PARAMS])
    assert list(data)[:4] == ["model", "parameters", "units", "provenance"]
    assert data["model"] == "rimless-wheel"
    assert data["parameters"] == {"alpha": ALPHA, "gamma": GAMMA, "l": LEG, "g": G}
    (gait,) = data["fixed_points"]
    assert gait["state"]["theta_dot"] == pytest.approx(omega_fixed(), rel=1e-9)
    assert gait["state"]["theta"] == pytest.approx(-ALPHA, rel=1e-12)
    assert gait["max_abs_eigenvalue"] == pytest.approx(math.cos(2 * ALPHA) ** 2, rel=1e-8)
    assert gait["eigenvalues"][0] == [pytest.approx(0.5, rel=1e-8), 0.0]
    assert gait["stable"] is True
    assert gait["step_length"] == pytest.approx(2 * LEG * math.sin(ALPHA), rel=1e-12)
    w0 = omega_fixed()

    def rate(theta):  # energy integral from theta = -alpha
        return math.sqrt(w0**2 + 2 * G / LEG * (math.cos(GAMMA - ALPHA) - math.cos(GAMMA + theta)))

    period = quad(lambda th: 1 / rate(th), -ALPHA, ALPHA, epsabs=0, epsrel=1e-13)[0]
    assert gait["period"] == pytest.approx(period, rel=1e-9)
    assert gait["speed"] == pytest.approx(2 * LEG * math.sin(ALPHA) / period, rel=1e-9)


def test_rimless_wheel_defaults_and_underscore_name(capsys):
    by_default = run_json(capsys, ["analyze", *RIMLESS])
    by_underscore = run_json(capsys, ["analyze", "--model", "rimless_wheel", *PARAMS])
    # the table's defaults are Drake's test parameters
    assert payload(by_default) == payload(by_underscore)


def test_rimless_wheel_analyze_text(capsys):
    code, out, err = run(capsys, ["analyze", *RIMLESS, "--param", "gamma=0.1"])
    assert code == 0 and err == ""
    assert "gait 1" in out and f"{omega_fixed(gamma=0.1):.6g}" in out


def test_rimless_wheel_json_on_a_clean_stdout():
    # CasADi and SciPy print nothing into the JSON or on stderr, in a real process too.
    proc = subprocess.run(
        [sys.executable, "-m", "vsw", "analyze", *RIMLESS, "--param", "gamma=0.1", "--json"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0 and proc.stderr == ""
    assert json.loads(proc.stdout)["fixed_points"][0]["stable"] is True


def test_rimless_wheel_simulate_follows_the_stride_map(capsys):
    argv = ["simulate", *RIMLESS, "--steps", "6", "--state", f"theta={-ALPHA!r}"]
    data = run_json(capsys, [*argv, "--state", "theta_dot=2"])
    assert data["ended"] == "completed" and data["steps_completed"] == 6
    assert data["start_from"] == "--state"
    omegas = [s["theta_dot"] for s in data["section_states"]]
    expected = [2.0]
    for _ in range(6):  # the collision keeps cos(2 alpha) of the rate (angular momentum)
        expected.append(math.cos(2 * ALPHA) * math.sqrt(omega_before_collision_sq(expected[-1])))
    np.testing.assert_allclose(omegas, expected, rtol=1e-9)
    assert data["step_lengths"] == [pytest.approx(2 * math.sin(ALPHA), rel=1e-12)] * 6
    from_gait = run_json(capsys, ["simulate", *RIMLESS, "--steps", "2"])
    assert from_gait["start_from"] == "gait" and from_gait["note"] is None
    for state in from_gait["section_states"]:
        assert state["theta_dot"] == pytest.approx(omega_fixed(), rel=1e-9)
    # --q0: the rate squared just after the collision, the spoke at -alpha (the section).
    by_q = run_json(capsys, ["simulate", *RIMLESS, "--steps", "2", "--q0", "4"])
    assert by_q["section_states"][0] == data["section_states"][0]
    assert by_q["q"][0] == pytest.approx(4.0, rel=1e-15)


@pytest.mark.parametrize(
    "omega, ended",
    [
        (-0.5, "fell-backward"),  # already rolling back at the start
        (0.5, "fell-backward"),  # below the apex bound
        (2.9, "lift-off"),  # above the lift-off bound, the spoke pulls before the collision
        (3.5, "lift-off"),  # the spoke already pulls at the start: g cos(gamma - alpha) < l w^2
    ],
)
def test_rimless_wheel_simulate_failures(capsys, omega, ended):
    assert (omega**2 < apex_bound_sq()) is (ended == "fell-backward")
    assert (omega**2 > lift_off_bound_sq()) is (ended == "lift-off")
    argv = ["simulate", *RIMLESS, "--steps", "3", "--state", f"theta={-ALPHA!r}"]
    data = run_json(capsys, [*argv, "--state", f"theta_dot={omega}"])
    assert data["ended"] == ended and data["steps_completed"] == 0


def test_rimless_wheel_basin_matches_the_apex_and_lift_off_bounds(capsys):
    """The one-component section's basin: the cells between the apex and lift-off bounds
    (derived here by hand) converge, those outside fall, each the right way."""
    argv = ["basin", *RIMLESS, "--grid", "theta_dot=-0.5:4:19"]
    data = run_json(capsys, argv)
    low, high = math.sqrt(apex_bound_sq()), math.sqrt(lift_off_bound_sq())
    assert data["gait"]["state"]["theta_dot"] == pytest.approx(omega_fixed(), rel=1e-9)
    assert data["y_name"] is None and data["y"] is None
    (outcome,), (ended,) = data["outcome"], data["ended"]
    assert len(data["x"]) == len(outcome) == 19
    checked = 0
    for omega, kind, end in zip(data["x"], outcome, ended):
        if min(abs(omega - low), abs(omega - high)) < 1e-3:
            continue
        checked += 1
        if low < omega < high:
            assert kind == "converged" and end == "converged", omega
        else:
            assert kind == "fell", omega
            assert end == ("fell-backward" if omega < low else "lift-off"), omega
    assert checked >= 17
    # Without --grid: the search box of its one free component.
    default = run_json(capsys, ["basin", *RIMLESS])
    assert default["x_name"] == "theta_dot" and len(default["x"]) == 41


def test_basin_of_a_wider_section_needs_a_grid(capsys):
    code, out, err = run(capsys, ["basin", "--model", "compass-gait"])
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "--grid twice" in err and "theta, theta_dot, psi_dot" in err
    code, out, err = run(capsys, ["basin", "--model", "compass-gait", "--grid", "theta=0:1:3"])
    assert code == 2 and "give --grid twice" in err


# --- sweep -----------------------------------------------------------------------------------


def test_rimless_wheel_sweep_over_gamma(capsys):
    data = run_json(capsys, ["sweep", *RIMLESS, "--over", "gamma=0.02:0.2:7"])
    assert data["over"] == "gamma" and "gamma" not in data["parameters"]
    gammas = [p["gamma"] for p in data["points"]]
    np.testing.assert_allclose(gammas, np.linspace(0.02, 0.2, 7), rtol=1e-15)
    found = [p for p in data["points"] if p["found"]]
    for p in data["points"]:
        # A rolling gait exists where Drake's rate passes the apex (no gait at 0.02, 0.05).
        exists = omega_fixed(gamma=p["gamma"]) ** 2 > apex_bound_sq(gamma=p["gamma"])
        assert p["found"] is exists, p["gamma"]
    assert len(found) == 5 and found[0]["from"] == "scan"
    assert all(p["from"] == "continuation" for p in found[1:])
    omegas = [p["state"]["theta_dot"] for p in found]
    assert all(b > a for a, b in itertools.pairwise(omegas))  # faster down steeper slopes
    for p in found:
        assert p["state"]["theta_dot"] == pytest.approx(omega_fixed(gamma=p["gamma"]), rel=1e-9)
        assert p["max_abs_eigenvalue"] == pytest.approx(math.cos(2 * ALPHA) ** 2, rel=1e-8)
        assert p["stable"] is True


def test_ile_sweep_matches_the_paper_fixed_point(capsys):
    beta, phi0 = 0.8, math.radians(45)
    data = run_json(
        capsys, ["sweep", "--beta", "0.8", "--phi0", "45", "--over", "theta_II=-0.1:0.3:5"]
    )
    assert data["model"] == "ile" and data["parameters"] == {"beta": beta, "phi0": phi0}
    c2 = math.cos(phi0) ** 2
    theta_I = -math.atan((beta - math.cos(phi0)) / math.sin(phi0))  # eq. (11)
    for p in data["points"]:
        theta_II = p["theta_II"]
        # eq. (7) at its fixed point: q = lambda q + 2 c^2 [...], lambda = beta^2 c^2 (19)
        free = (
            2
            * c2
            * (math.cos(theta_II) * (1 / beta**2 - beta) - math.cos(theta_I) * (1 / beta - beta))
        )
        assert p["q_fixed"] == pytest.approx(free / (1 - beta**2 * c2), rel=1e-12)
        assert p["eigenvalue"] == pytest.approx(beta**2 * c2, rel=1e-12)
        assert p["walks"] is True


def test_ile_sweep_text(capsys):
    code, out, err = run(
        capsys, ["sweep", "--beta", "0.8", "--phi0", "45", "--over", "theta_II=0:0.2:3"]
    )
    assert code == 0 and err == "" and "q_fixed" in out and len(out.splitlines()) == 5


# --- --param and the ILE ---------------------------------------------------------------------


def test_ile_param_equals_named_options(capsys):
    named = run_json(capsys, ["analyze", "--beta", "0.8", "--theta-ii", "5", "--phi0", "45"])
    params = ["--param", "beta=0.8", "--param", f"theta_II={math.radians(5)!r}"]
    params += ["--param", f"phi0={math.pi / 4!r}"]
    assert payload(run_json(capsys, ["analyze", *params])) == payload(named)
    mixed = ["analyze", "--beta", "0.8", "--theta-ii", "5", "--param", f"phi0={math.pi / 4!r}"]
    assert payload(run_json(capsys, mixed)) == payload(named)
    in_degrees = ["analyze", "--param", "beta=0.8", "--param", "theta_II=5deg", "--phi0", "45"]
    assert payload(run_json(capsys, in_degrees)) == payload(named)
    argv = ["simulate", "--beta", "0.8", "--theta-ii", "5", "--q0", "0.3", "--steps", "2"]
    assert payload(run_json(capsys, [*argv, "--phi0", "45"])) == payload(
        run_json(capsys, [*argv, "--param", f"phi0={math.pi / 4!r}"])
    )


def test_defaults_apply_to_every_model_the_ile_included(capsys):
    import generated.ile.params as table

    data = run_json(capsys, ["analyze"])
    defaults = {p.name: p.default for p in table.PARAMETERS}
    assert data["parameters"] == defaults and data["model"] == "ile"
    assert data["beta"] == defaults["beta"] and data["walks"] is True
    one = run_json(capsys, ["analyze", "--param", "beta=0.7"])
    assert one["parameters"] == {**defaults, "beta": 0.7}


def test_named_parameters_serve_every_model_that_has_them(capsys):
    biped = ["simulate", "--model", "vsw-biped", "--steps", "1", "--state", "theta=-0.2",
             "--state", "psi=0.5", "--state", "theta_dot=0.5", "--state", "psi_dot=-1"]  # fmt: skip
    data = run_json(capsys, [*biped, "--beta", "0.9", "--theta-ii", "-5"])
    assert data["parameters"]["beta"] == 0.9
    assert data["parameters"]["theta_II"] == pytest.approx(math.radians(-5), rel=1e-15)
    code, out, err = run(capsys, [*biped, "--phi0", "45"])
    assert code == 2 and out == "" and "--phi0: vsw-biped has no parameter phi0" in err


def test_sweep_over_an_angle_in_degrees(capsys):
    rad = run_json(capsys, ["sweep", "--over", f"theta_II={math.radians(-10)!r}:0:3"])
    deg = run_json(capsys, ["sweep", "--over", "theta_II=-10deg:0deg:3"])
    assert payload(rad) == payload(deg)


ILE_ANALYZE = ["analyze", "--beta", "0.8", "--theta-ii", "0"]
ILE_SIMULATE = ["simulate", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45"]
BAD = [
    (["analyze", *RIMLESS, "--param", "alpha=2"], ["alpha", "(0, 1.5708) rad"]),
    (["analyze", *RIMLESS, "--param", "alpha=abc"], ["alpha", "(0, 1.5708)"]),
    (["analyze", *RIMLESS, "--param", "gamma=nan"], ["gamma", "(-1.5708, 1.5708)"]),
    (["analyze", *RIMLESS, "--param", "l=0"], ["l ", "(0, inf) m"]),
    (["analyze", *RIMLESS, "--param", "g=inf"], ["g ", "(0, inf)"]),
    (["analyze", *RIMLESS, "--param", "beta=0.5"], ["'beta'", "alpha, gamma, l, g"]),
    (["analyze", *RIMLESS, "--param", "alpha=0.3", "--param", "alpha=0.4"], ["twice"]),
    (["analyze", *RIMLESS, "--param", "alpha"], ["NAME=VALUE"]),
    (["analyze", *RIMLESS, "--beta", "0.8"], ["--beta", "no parameter beta"]),
    (["analyze", *RIMLESS, "--stepper-2d"], ["--stepper-2d"]),
    (["analyze", "--model", "walker"], ["walker", "rimless-wheel"]),
    ([*ILE_ANALYZE, "--param", "phi0=2"], ["phi0", "(0, 1.5708) rad", "eq. (16)"]),
    ([*ILE_ANALYZE, "--phi0", "45", "--param", "beta=0.7"], ["twice"]),
    (["basin", "--beta", "0.8", "--phi0", "45", "--param", "theta_II=0"], ["axis"]),
    (["basin", "--beta", "0.8", "--phi0", "45", "--n-rates", "5"], ["--n-rates"]),
    (["basin", *RIMLESS, "--theta-step", "5"], ["--theta-step"]),
    (["basin", *RIMLESS, "--grid", "theta_dot=2:1:5"], ["START = 2"]),
    (["basin", *RIMLESS, "--grid", "theta=0:1:5"], ["theta follows from theta_dot"]),
    (["basin", *RIMLESS, "--grid", "theta_dot=0:1:1"], ["from 2 to"]),
    (["basin", *RIMLESS, "--tol", "nan"], ["--tol"]),
    (["simulate", "--model", "compass-gait", "--steps", "2", "--q0", "1"], ["--q0", "rimless"]),
    (["simulate", *RIMLESS, "--q0", "-1"], ["--q0 = -1"]),
    (["simulate", *RIMLESS, "--steps", "2", "--state", "theta=0"], ["theta_dot"]),
    (["simulate", *RIMLESS, "--plot", "x.txt"], ["plot file 'x.txt' must end in one of"]),
    (["design", "--model", "tle"], ["give an objective"]),
    (["design", "--model", "tle", "--maximize", "speed", "--fix", "beta=2"], ["beta", "(0, 1)"]),
    (["explore", "--model", "compass-gait", "--out", "x.txt"], [".html"]),
    (["analyze", *RIMLESS, "--search", "theta=0:1"], ["--search theta", "theta_dot"]),
    (["analyze", *RIMLESS, "--search", "theta_dot=1:0"], ["START = 1"]),
    (["simulate", *RIMLESS, "--steps", "2", "--state", "x=0"], ["'x'"]),
    (["simulate", *RIMLESS, "--steps", "0"], ["steps"]),
    ([*ILE_SIMULATE, "--q0", "0.3", "--steps", "1", "--state", "theta_dot=1"], ["--state"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2"], ["START:STOP:N"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:2:3"], ["gamma", "(-1.5708, 1.5708)"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2:0"], ["N"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2:3", "--param", "gamma=0.1"], ["--over"]),
    (["sweep", "--over", "phi0=0.1:0.2:3", *ILE_ANALYZE[1:], "--phi0", "4"], ["--over"]),
    (["sweep", "--over", "phi0=1deg:100deg:3"], ["phi0=100deg = 100 deg", "(0, 1.5708) rad"]),
    (["sweep", "--beta", "0.8", "--theta-ii", "0"], ["--over"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2:2", "--keep", "1"], ["--keep 1"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2:2", "--keep", "-3"], ["--keep -3"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2:2", "--transient", "5"], ["--keep N"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2:2", "--keep", "4", "--transient", "-1"],
     ["--transient -1"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2:2", "--y", "theta"], ["--plot FILE"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2:2", "--y=nope", "--plot", "x.png"],
     ["'nope'", "step_length"]),
    (["sweep", *RIMLESS, "--over", "gamma=0.1:0.2:2", "--plot", "x.txt"], [".png"]),
    (["sweep", "--beta", "0.8", "--phi0", "45", "--over", "theta_II=0:0.1:2", "--keep", "4"],
     ["--keep"]),
]  # fmt: skip


@pytest.mark.parametrize("argv, words", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_model_input_is_one_line_exit_2(capsys, argv, words):
    code, out, err = run(capsys, argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    for word in words:
        assert word in err, err


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", *RIMLESS, "--steps", "1000000000"],
        ["basin", *RIMLESS, "--grid", "theta_dot=0:4:4000", "--steps", "100000"],
        ["sweep", *RIMLESS, "--over", "gamma=0.05:0.2:100000"],
        ["sweep", "--beta", "0.8", "--phi0", "45", "--over", "theta_II=-0.2:0.2:100000"],
    ],
)
def test_large_model_work_is_refused_at_once(capsys, monkeypatch, argv):
    monkeypatch.setenv("VSW_MAX_SECONDS", "5")  # 10^5 ILE points: about 10 s
    code, out, err = run(capsys, argv)
    assert code == 2 and out == "" and err.count("\n") == 1 and "VSW_MAX_" in err


def test_solver_failure_at_extreme_parameters_is_one_line(capsys):
    # A spoke angle of 1e-9 rad: collisions at once; CVODES fails on non-finite states.
    code, out, err = run(capsys, ["analyze", *RIMLESS, "--param", "alpha=1e-9", "--json"])
    assert code in (0, 3) and err.count("\n") == (code == 3)
    if code == 0:
        json.loads(out)


def test_ile_sweep_plot_writes_the_figure(capsys, tmp_path):
    """``vsw sweep --plot`` on the ILE: q^f, eigenvalue and speed along the parameter."""
    plot = tmp_path / "ile_sweep.svg"
    data = run_json(capsys, ["sweep", "--beta", "0.8", "--phi0", "45", "--over",
                             "theta_II=0:0.2:5", "--plot", str(plot)])  # fmt: skip
    assert data["plot"] == str(plot)
    text = plot.read_text()
    assert text.startswith("<?xml") and "</svg>" in text
