"""The energy ledger (vsw/dynamics/ledger.py) beside what it must equal from elsewhere: the paper's
energy balance of the ILE as printed, the slope's work on the compass gait, Carnot's loss.

* [ILE] ../shared/paper/instantaneous_leg_extension_vsw.md, section E: the energy the
  extension adds, E_c (20), and heelstrike dissipates, E_r (21), in units of m g r_e, at
  q = omega_I**2 (the rate just after heelstrike, in sqrt(g / r_e)) and theta_I (the
  stance angle there).
* [GTE96] the compass gait on a slope gamma: over a step gravity does M g sin(gamma) times
  the step length (the walker's height falls by that along the slope; M = m_h + 2 m).
"""

from __future__ import annotations

import dataclasses
import io
import math

import numpy as np
import pytest

from derive.engine.hybrid import hybrid_quantities
from derive.models import vsw_biped_phi0 as caught
from vsw.cli import main
from vsw.cli.analyze import _write_ledger
from vsw.dynamics.ledger import energy_ledger
from vsw.models import load


def _paper_energies(beta: float, theta_ii: float, phi0: float, q: float, theta_i: float):
    """E_c (20) and E_r (21) of [ILE] as printed, m g r_e = 1."""
    bracket = (1 - beta**3) * math.cos(theta_ii) - (beta - beta**3) * math.cos(theta_i)
    added = -0.5 * (beta**2 - beta**4) * q + bracket
    lost = 0.5 * beta**4 * (1 - math.cos(phi0) ** 2) * q + (1 - math.cos(phi0) ** 2) * bracket
    return added, lost


@pytest.mark.parametrize(
    "overrides", [{}, {"beta": 0.9, "theta_II": 0.1}, {"beta": 0.85, "theta_II": -0.05}]
)
def test_ile_extension_and_heelstrike_are_the_papers_energies(overrides):
    """The ledger's extension work (the jump's energy change, kinetic and potential) and
    heelstrike loss (Carnot's, from the hip's velocity jump) at the ILE's gait are [ILE]'s
    (20) and (21) at its fixed point, to 1e-9; they are equal on a gait."""
    m = load("ile")
    params = m.parameters(overrides)
    (orbit,) = m.fixed_points(params)
    ledger = energy_ledger(m, params, orbit)
    extension, heelstrike = ledger["events"]
    assert (extension["event"], heelstrike["event"]) == ("extension", "heelstrike")
    beta, theta_ii, phi0 = params
    added, lost = _paper_energies(
        beta, theta_ii, phi0, orbit.state["theta_dot"] ** 2, orbit.state["theta"]
    )
    assert extension["actuator_work"] == pytest.approx(added, rel=1e-9)
    assert heelstrike["loss"] == pytest.approx(lost, rel=1e-9)
    assert added == pytest.approx(lost, rel=1e-8)  # the gait: (22) E_delta = 0


@pytest.mark.parametrize("theta_ii", [0.1, -0.05])
def test_the_ground_gives_the_extension_a_push_then_a_pull(theta_ii):
    """The ground's impulse at the ILE's extension (the walker's change of momentum, from
    the ledger's body velocities) against [ILE]: the hip mass keeps its angular momentum
    about the foot, (3) omega_III = beta**2 omega_II, so its speed drops from
    beta omega_II to beta**2 omega_II across the leg: the impulse is
    -beta (1 - beta) omega_II (cos theta_II, -sin theta_II), with omega_II**2 = q +
    2 (cos theta_I - cos theta_II) / beta (energy in the short stance). Across the leg, so
    the leg's own net impulse is zero (a push, then a pull); before mid-stance
    (theta_II < 0) it points down: the foot is pulled on balance."""
    m = load("ile")
    params = m.parameters({"beta": 0.9, "theta_II": theta_ii})
    (orbit,) = m.fixed_points(params)
    (extension, _) = energy_ledger(m, params, orbit)["events"]
    beta = params[0]
    q, theta_i = orbit.state["theta_dot"] ** 2, orbit.state["theta"]
    omega = math.sqrt(q + 2 * (math.cos(theta_i) - math.cos(theta_ii)) / beta)
    size = -beta * (1 - beta) * omega
    expected = (size * math.cos(theta_ii), -size * math.sin(theta_ii))
    assert extension["ground_impulse"] == pytest.approx(expected, rel=1e-9)
    assert (extension["ground_impulse"][1] < 0) == (theta_ii < 0)


def test_compass_gait_gravity_work_is_the_slopes():
    """[GTE96]: gravity's work over a step is M g sin(gamma) times the step length, and
    heelstrike dissipates it (no actuator: its remainder is zero)."""
    m = load("compass-gait")
    params = m.parameters({})
    values = {p.name: v for p, v in zip(m.parameter_table, params)}
    weight_along = (values["m_h"] + 2 * values["m"]) * values["g"] * math.sin(values["gamma"])
    for orbit in m.fixed_points(params):
        totals = energy_ledger(m, params, orbit)["totals"]
        assert totals["gravity_work"] == pytest.approx(weight_along * orbit.step_length, rel=1e-9)
        assert totals["losses"] == pytest.approx(totals["gravity_work"], rel=1e-8)
        assert abs(totals["actuator_work_impulsive"]) < 1e-9 * totals["losses"]


@pytest.mark.parametrize("theta_ii", [0.1, -0.05])
def test_analyze_names_the_ground_impulse_of_an_extension(theta_ii):
    """`vsw analyze`'s ledger lines name the extension's ground impulse and say when the
    foot is pulled on balance: for the ILE extending before mid-stance only."""
    m = load("ile")
    params = m.parameters({"beta": 0.9, "theta_II": theta_ii})
    (orbit,) = m.fixed_points(params)
    out = io.StringIO()
    _write_ledger(out, m, energy_ledger(m, params, orbit))
    (line,) = (x for x in out.getvalue().splitlines() if "ground impulse" in x)
    assert "extension forward -" in line, line
    assert ("the foot is pulled on balance" in line) == (theta_ii < 0), line


def test_actuators_are_named_where_they_work():
    """``Model.actuators`` names who holds each coordinate: `vsw models` and the ledger
    say the caught biped's hip catches the swing leg (its loss is the hip's work) and its
    leg extends; the torso walker's hip works in stance and through heelstrike; a model
    naming an actuator for a coordinate no phase holds is refused when derived."""
    m = load("vsw-biped-phi0")
    description = m.describe()
    assert description["actuator_names"] == {"r": "leg", "phi": "hip"}
    assert description["actuated"] == {"catch": ["phi"], "extension": ["r"]}
    params = m.parameters({})
    # The default gait (vsw analyze --model vsw-biped-phi0), refined by Newton: the search
    # would take half a minute with a cold cache.
    start = np.array([0.0540306, -0.4, 0.7026009, 2.2784354])
    orbit = m.periodic_orbit(params, start, m.step(params, start).durations)
    assert orbit.max_abs_eigenvalue < 1
    events = {e["event"]: e for e in energy_ledger(m, params, orbit)["events"]}
    assert events["catch"]["caught_by"] == ("hip",) and events["catch"]["loss"] > 0
    assert events["extension"]["actuators"] == ("leg",)
    assert "caught_by" not in events["heelstrike"]
    torso = load("torso-walker")
    params = torso.parameters({})
    ledger = energy_ledger(torso, params, torso.fixed_points(params)[0])
    assert set(ledger["totals"]["actuators"]) == {"hip"}
    assert ledger["events"][-1]["actuators"] == ("hip",)
    unheld = dataclasses.replace(caught.MODEL, actuators={caught.theta: "ankle"})
    with pytest.raises(ValueError, match="actuators name coordinates no phase holds"):
        hybrid_quantities(unheld)


def test_vsw_models_names_each_actuator_where_it_works(capsys):
    """`vsw models` names the actuators by the models' names: the caught biped's leg at its
    extension and its hip catching, the held-hip biped's extension as leg and hip."""
    assert main(["models"]) == 0
    lines = [x.strip() for x in capsys.readouterr().out.splitlines() if "actuators doing" in x]
    assert (
        "actuators doing work: leg (r) at the jump at extension; hip (phi) catching at "
        "catch" in lines
    )
    assert "actuators doing work: leg and held hip (r) at the jump at extension" in lines
    assert "actuators doing work: hip (phi) in stance" in lines
