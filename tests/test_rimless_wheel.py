"""The engine's rimless wheel against Drake's (RobotLocomotion/drake, examples/rimless_wheel).

What Drake states, written out here independently of the engine:

* examples/rimless_wheel/test/rimless_wheel_test.cc, ``StepTest`` ("From the course
  notes, the rolling fixed point is at"): just after a collision
  ``theta = slope - alpha`` and
  ``thetadot = cos(2 alpha) / sin(2 alpha) * sqrt(4 g / l * sin(alpha) * sin(slope))``,
  with ``alpha = pi / number_of_spokes``. The same test walks one step from a point of the
  limit cycle just before a collision (``theta = slope + alpha / 2`` at the steady-state
  energy) and finds the same energy after it and the toe one step length on; 0.2 rad/s
  faster loses energy, 0.2 rad/s slower gains it (by more than 0.01).
* examples/rimless_wheel/rimless_wheel.cc: stance ``thetaddot = sin(theta) g / l``;
  collision ``thetadot <- thetadot cos(2 alpha)``, ``toe += 2 l sin(alpha)``; energy
  ``1/2 m l**2 thetadot**2 + m g l cos(theta)``.
* examples/rimless_wheel/rimless_wheel_params_named_vector.yaml: defaults mass 1, length 1,
  gravity 9.81, number_of_spokes 8, slope 0.08.

Drake's ``theta`` is the stance spoke's angle from the vertical; the engine's is from the
slope normal: ``theta_drake = theta + gamma``. Drake's mass cancels (energies per unit
mass here).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import generated.rimless_wheel as rw
from vsw.models import load

DRAKE_DEFAULTS = (8, 0.08, 1.0, 9.81)
"""(number_of_spokes, slope, length, gravity) of rimless_wheel_params_named_vector.yaml."""

CASES = [DRAKE_DEFAULTS, (6, 0.2, 1.0, 9.81), (10, 0.05, 0.5, 9.81), (12, 0.1, 2.0, 1.62),
         (16, 0.04, 1.0, 9.81)]  # fmt: skip
"""Drake's defaults and other wheels that roll (past the apex, the foot kept down)."""


def engine_parameters(spokes: int, slope: float, length: float, gravity: float) -> dict:
    return {"alpha": math.pi / spokes, "gamma": slope, "l": length, "g": gravity}


def drake_fixed_point(spokes: int, slope: float, length: float, gravity: float):
    """(theta, thetadot) just after a collision on Drake's rolling limit cycle, in Drake's
    angle (from the vertical); rimless_wheel_test.cc, StepTest."""
    alpha = math.pi / spokes
    theta = slope - alpha
    thetadot = (math.cos(2 * alpha) / math.sin(2 * alpha)
                * math.sqrt(4 * gravity / length * math.sin(alpha) * math.sin(slope)))  # fmt: skip
    return theta, thetadot


def drake_energy(theta_drake: float, thetadot: float, length: float, gravity: float) -> float:
    """rimless_wheel.cc, CalcTotalEnergy, per unit mass."""
    return 0.5 * (length * thetadot) ** 2 + gravity * length * math.cos(theta_drake)


def test_defaults_are_drakes():
    m = load("rimless-wheel")
    assert m.parameters({}) == tuple(engine_parameters(*DRAKE_DEFAULTS).values())


@pytest.mark.parametrize("case", CASES, ids=lambda c: "spokes{}-slope{}-l{}-g{}".format(*c))
def test_closed_form_fixed_point_is_drakes(case):
    spokes, slope, _, _ = case
    p = tuple(engine_parameters(*case).values())
    theta, thetadot = drake_fixed_point(*case)
    assert math.sqrt(rw.q_fixed(*p)) == pytest.approx(thetadot, rel=1e-14)
    assert rw.section_angle(*p) + slope == pytest.approx(theta, rel=1e-15, abs=1e-15)
    # Stability: the collision scales thetadot by cos(2 alpha) (rimless_wheel.cc) and the
    # stance adds a constant to thetadot**2 (energy), so the map in q has slope cos**2.
    assert rw.eigenvalue(*p) == pytest.approx(math.cos(2 * math.pi / spokes) ** 2, rel=1e-14)


@pytest.mark.parametrize("case", CASES, ids=lambda c: "spokes{}-slope{}-l{}-g{}".format(*c))
def test_orbit_and_simulation_reach_drakes_fixed_point(case):
    spokes, slope, length, _ = case
    m = load("rimless-wheel")
    p = m.parameters(engine_parameters(*case))
    theta, thetadot = drake_fixed_point(*case)
    drake = np.array([theta - slope, thetadot])
    orbits = m.fixed_points(p)
    assert len(orbits) == 1  # the rolling gait; Drake's standing fixed point is no walk
    orbit = orbits[0]
    np.testing.assert_allclose(list(orbit.state.values()), drake, rtol=1e-9, atol=1e-12)
    alpha = math.pi / spokes
    assert orbit.max_abs_eigenvalue == pytest.approx(math.cos(2 * alpha) ** 2, rel=1e-8)
    assert orbit.step_length == pytest.approx(2 * length * math.sin(alpha), rel=1e-14)
    # Drake's state is a fixed point of the engine's simulated step ...
    np.testing.assert_allclose(m.step(p, drake).state, drake, rtol=1e-9, atol=1e-12)
    # ... and walks from 20 % too fast converge to it (|slope| <= cos**2(pi/8) < 0.86).
    x = np.array([theta - slope, 1.2 * thetadot])
    for _ in range(200):
        result = m.step(p, x)
        assert result.ended == "completed"
        x = result.state
    np.testing.assert_allclose(x, drake, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("case", CASES, ids=lambda c: "spokes{}-slope{}-l{}-g{}".format(*c))
def test_drakes_step_test(case):
    """rimless_wheel_test.cc, StepTest, with the engine's simulation: from a point of the
    limit cycle before a collision one step keeps the steady-state energy (Drake: to 1e-5
    at accuracy 1e-8; here to 1e-9); 0.2 rad/s faster loses energy, 0.2 slower gains it."""
    spokes, slope, length, gravity = case
    m = load("rimless-wheel")
    p = m.parameters(engine_parameters(*case))
    alpha = math.pi / spokes
    steady = drake_energy(*drake_fixed_point(*case), length, gravity)
    theta = slope + alpha / 2  # Drake's angle
    thetadot = math.sqrt(2 * (steady - gravity * length * math.cos(theta)) / length**2)
    for change, sign in ((0.0, 0), (0.2, -1), (-0.2, +1)):
        start = np.array([theta - slope, thetadot + change])
        before = drake_energy(theta, thetadot + change, length, gravity)
        assert rw.stance_energy(*p, *start) == pytest.approx(before, rel=1e-14)
        trajectory = m.simulate(p, start, steps=1)
        assert trajectory.ended == "completed" and trajectory.steps_completed == 1
        after_state = trajectory.section[-1]
        after = drake_energy(after_state[0] + slope, after_state[1], length, gravity)
        assert after_state[0] + slope == pytest.approx(slope - alpha, abs=1e-14)
        if sign == 0:
            assert after == pytest.approx(steady, rel=1e-9)
        else:
            assert sign * (after - before) > 0.01


def test_stance_collision_and_energy_are_drakes():
    """The derived stance dynamics, collision and energy are rimless_wheel.cc's."""
    m = load("rimless-wheel")
    # The engine names event functions event_<event>_*; before that <event>_*.
    guard = getattr(rw, "event_collision_guard", None) or rw.collision_guard
    rng = np.random.default_rng(5)
    for _ in range(50):
        spokes = int(rng.integers(4, 20))
        slope, length, gravity = rng.uniform(-0.3, 0.3), rng.uniform(0.2, 3), rng.uniform(1, 20)
        p = tuple(engine_parameters(spokes, slope, length, gravity).values())
        alpha = p[0]
        theta, omega = rng.uniform(-alpha, alpha), rng.uniform(-4, 4)
        (acc,) = rw.stance_accelerations(*p, theta, omega)
        assert acc == pytest.approx(math.sin(theta + slope) * gravity / length, rel=1e-13)
        assert rw.stance_energy(*p, theta, omega) == pytest.approx(
            drake_energy(theta + slope, omega, length, gravity), rel=1e-13
        )
        # StepForwardGuard: theta_drake = slope + alpha; StepForwardReset.
        assert guard(*p, alpha, omega) == pytest.approx(0.0, abs=1e-15)
        assert guard(*p, alpha - 1e-6, omega) > 0  # the next foot is above the slope before
        theta_after, omega_after = m.reset("collision", p, np.array([alpha, omega]))
        assert theta_after + slope == pytest.approx(slope - alpha, abs=1e-15)
        assert omega_after == pytest.approx(omega * math.cos(2 * alpha), rel=1e-14)
        length_of_step = m.step_length(p, np.array([alpha, omega]))
        assert length_of_step == pytest.approx(2 * length * math.sin(alpha), rel=1e-15)
