"""Continuous inputs in the model language (derive/engine/model.py ``Input``): the compass
gait's hip torque, as Drake's CompassGait has it.

The engine derives each input's gain on the accelerations from its virtual work and the
phase's equations of motion (Kane's method). Checked here by what the derivation did not
use: Newton and Euler written out for the three point masses (the walker's angular momentum
about the stance foot, on which the hip torque does nothing, and the swing leg's about the
hip, on which it acts), and the energy balance (the input's power is the rate of the
walker's energy).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import sympy as sm

import generated.compass_gait as gen
from derive.engine.hybrid import phase_dynamics
from derive.engine.model import Input
from derive.models import compass_gait
from vsw.cli import main

PARAMETER_NAMES = ("m_h", "m", "a", "b", "gamma", "g")


def _random_cases(count: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        params = (rng.uniform(0.5, 20), rng.uniform(0.1, 10), rng.uniform(0.2, 1.5),
                  rng.uniform(0.2, 1.5), rng.uniform(0.0, 0.3), rng.uniform(1, 20))  # fmt: skip
        state = (*rng.uniform(-0.8, 0.8, 2), *rng.uniform(-3, 3, 2))
        yield params, state, rng.uniform(-50, 50)


def _accelerations(params, state, torque):
    passive = np.array(gen.stance_accelerations(*params, *state), dtype=float)
    gains = np.array(gen.stance_input_gains(*params, *state), dtype=float)
    return passive + gains * torque


def _point_acceleration(length, angle, rate, acc):
    """Second derivative of ``length * (sin angle, cos angle)``."""
    return length * np.array([np.cos(angle) * acc - np.sin(angle) * rate**2,
                              -np.sin(angle) * acc - np.cos(angle) * rate**2])  # fmt: skip


def _ground(params, state, torque):
    """The ground's force on the stance foot from Newton: sum of m (a - g) over the bodies."""
    m_h, m, a, b, gamma, g = params
    theta, psi, theta_dot, psi_dot = state
    theta_acc, psi_acc = _accelerations(params, state, torque)
    gravity = np.array([g * np.sin(gamma), -g * np.cos(gamma)])
    hip_acc = _point_acceleration(a + b, theta, theta_dot, theta_acc)
    stance_acc = _point_acceleration(a, theta, theta_dot, theta_acc)
    swing_acc = hip_acc - _point_acceleration(b, psi, psi_dot, psi_acc)
    return m_h * (hip_acc - gravity) + m * (stance_acc - gravity) + m * (swing_acc - gravity)


def _cross(p, f):
    return p[0] * f[1] - p[1] * f[0]


def test_the_hip_torque_obeys_newton_and_euler():
    """With the hip torque ``u`` (CCW on the swing leg, so that its power is
    ``u (theta' - psi')``), at random parameters, states and torques: the walker's angular
    momentum about the stance foot changes by gravity's moment alone (the torque is
    internal), the swing leg's about the hip by gravity's moment and ``u``; the ground
    reaction with the input's gains is the bodies' rate of momentum minus gravity."""
    for params, state, u in _random_cases(40, seed=28):
        m_h, m, a, b, gamma, g = params
        theta, psi, theta_dot, psi_dot = state
        theta_acc, psi_acc = _accelerations(params, state, u)
        gravity = np.array([g * np.sin(gamma), -g * np.cos(gamma)])
        hip = (a + b) * np.array([np.sin(theta), np.cos(theta)])
        hip_acc = _point_acceleration(a + b, theta, theta_dot, theta_acc)
        stance = a * np.array([np.sin(theta), np.cos(theta)])
        stance_acc = _point_acceleration(a, theta, theta_dot, theta_acc)
        swing = hip - b * np.array([np.sin(psi), np.cos(psi)])
        swing_acc = hip_acc - _point_acceleration(b, psi, psi_dot, psi_acc)
        walker = sum(mass * (_cross(p, acc) - _cross(p, gravity))
                     for mass, p, acc in ((m_h, hip, hip_acc), (m, stance, stance_acc),
                                          (m, swing, swing_acc)))  # fmt: skip
        scale = (m_h + 2 * m) * (a + b) * (g + (a + b) * (theta_dot**2 + psi_dot**2)) + abs(u)
        assert abs(walker) <= 1e-12 * scale
        lever = swing - hip
        swing_leg = m * (_cross(lever, swing_acc) - _cross(lever, gravity)) - u
        assert abs(swing_leg) <= 1e-12 * scale
        # The ground's force on the foot: the bodies' rate of momentum minus gravity.
        ground = sum(mass * (acc - gravity) for mass, acc in ((m_h, hip_acc), (m, stance_acc),
                                                              (m, swing_acc)))  # fmt: skip
        normal_gain, tangential_gain = gen.stance_reaction_input_gains(*params, *state)
        normal = gen.stance_normal_force(*params, *state) + normal_gain * u
        assert abs(normal - ground[1]) <= 1e-12 * scale
        (lift_off_gain,) = gen.stance_lift_off_input_gains(*params, *state)
        assert lift_off_gain == pytest.approx(normal_gain, rel=1e-12, abs=1e-12)
        # No tangential force is generated: its gain is checked as the input's share.
        assert abs(tangential_gain * u - (ground[0] - _ground(params, state, 0.0)[0])) <= (
            1e-12 * scale
        )


def test_the_inputs_power_is_the_rate_of_the_walkers_energy():
    """dE/dt along the flow with the input on is ``u`` times the input's rate: the energy's
    derivative by the rates (central differences of the generated energy) times the gains
    is that rate, at random states (the passive flow keeps E)."""
    for params, state, _ in _random_cases(40, seed=29):
        theta_dot, psi_dot = state[2:]
        gains = np.array(gen.stance_input_gains(*params, *state), dtype=float)
        h = 1e-6
        by_rates = []
        for k in (2, 3):
            up, down = list(state), list(state)
            up[k] += h
            down[k] -= h
            by_rates.append((gen.stance_energy(*params, *up)
                             - gen.stance_energy(*params, *down)) / (2 * h))  # fmt: skip
        (rate,) = gen.stance_input_rates(*params, *state)
        assert rate == pytest.approx(theta_dot - psi_dot, abs=1e-15)
        scale = max(1.0, abs(rate), float(np.max(np.abs(by_rates))) * float(np.max(np.abs(gains))))
        assert abs(float(np.dot(by_rates, gains)) - rate) <= 1e-7 * scale


def test_the_descriptor_names_the_input_and_the_gains_outputs():
    """HYBRID's phase record names the input, its actuator and unit; the gains' outputs are
    named by coordinate and input. (That the passive functions did not change is
    ``derive --check``'s: they were byte-identical after the inputs came in.)"""
    (phase,) = gen.HYBRID["phases"]
    (record,) = phase["inputs"]
    assert (record["name"], record["actuator"], record["unit"]) == ("hip_torque", "hip", "N m")
    assert gen.stance_input_gains.outputs == ("theta/hip_torque", "psi/hip_torque")
    assert gen.stance_lift_off_input_gains.outputs == ("hip_torque",)


@pytest.mark.parametrize(
    ("inputs", "message"),
    [
        ((Input("push", compass_gait.a, "hip"),), "no free coordinate changes"),
        ((Input("u", compass_gait.theta, "hip"), Input("u", compass_gait.psi, "hip")),
         "input names repeat"),
        ((Input("u", compass_gait.theta, "hip", bounds=(1.0, -1.0)),), "bounds"),
    ],
)  # fmt: skip
def test_inputs_that_cannot_act_are_refused(inputs, message):
    """An input along a parameter does no work; names repeat; empty bounds: one line each."""
    phase = dataclasses.replace(compass_gait.STANCE, inputs=inputs)
    with pytest.raises(ValueError, match=message):
        phase_dynamics(phase)


def test_vsw_models_names_the_input(capsys):
    """`vsw models` says which inputs a phase has, by whom and along what (text and JSON)."""
    assert main(["models", "--model", "compass-gait"]) == 0
    text = capsys.readouterr().out
    assert "inputs in stance (zero when walking passively): hip_torque [N m] by the hip" in text
    assert main(["models", "--model", "compass-gait", "--json"]) == 0
    ((model,),) = [json.loads(capsys.readouterr().out)["models"]]
    (record,) = model["inputs"]["stance"]
    assert record["along"] == "-psi + theta" and record["bounds"] == [None, None]
    assert main(["models", "--model", "simplest-walker", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["models"][0]["inputs"] == {}


def test_an_input_in_a_phase_that_holds_a_coordinate_obeys_newton_and_euler():
    """The VSW biped's short phase holds its stance leg at beta (derive/models/vsw_biped.py);
    a hip torque declared on it here (the model has none) must give the accelerations
    Newton and Euler give: the walker's angular momentum about the foot changes by
    gravity's moment alone (the leg's force passes through the foot, the torque is
    internal), the swing leg's about the hip by gravity's moment and the torque."""
    from derive.models import vsw_biped as biped

    phase = dataclasses.replace(
        biped.SHORT, inputs=(Input("hip_torque", biped.theta - biped.psi, "hip"),)
    )
    dyn = phase_dynamics(phase)
    symbols = (biped.beta, biped.mu, biped.b, biped.theta, biped.psi,
               biped.THETA.u, biped.PSI.u)  # fmt: skip
    passive = sm.lambdify(symbols, list(dyn.accelerations), "numpy")
    gains = sm.lambdify(symbols, [row[0] for row in dyn.input_gains], "numpy")
    rng = np.random.default_rng(31)
    gravity = np.array([0.0, -1.0])
    for _ in range(30):
        beta, mu, b = rng.uniform(0.5, 1.0), rng.uniform(0.01, 2.0), rng.uniform(0.1, 0.9)
        theta, psi, theta_dot, psi_dot = (*rng.uniform(-0.6, 0.6, 2), *rng.uniform(-2, 2, 2))
        u = rng.uniform(-2, 2)
        args = (beta, mu, b, theta, psi, theta_dot, psi_dot)
        theta_acc, psi_acc = np.array(passive(*args)) + u * np.array(gains(*args))
        hip = beta * np.array([np.sin(theta), np.cos(theta)])
        hip_acc = _point_acceleration(beta, theta, theta_dot, theta_acc)
        stance = hip - b * np.array([np.sin(theta), np.cos(theta)])
        stance_acc = hip_acc - _point_acceleration(b, theta, theta_dot, theta_acc)
        swing = hip - b * np.array([np.sin(psi), np.cos(psi)])
        swing_acc = hip_acc - _point_acceleration(b, psi, psi_dot, psi_acc)
        walker = sum(mass * (_cross(p, acc) - _cross(p, gravity))
                     for mass, p, acc in ((1.0, hip, hip_acc), (mu, stance, stance_acc),
                                          (mu, swing, swing_acc)))  # fmt: skip
        lever = swing - hip
        swing_leg = mu * (_cross(lever, swing_acc) - _cross(lever, gravity)) - u
        scale = (1 + 2 * mu) * (1 + theta_dot**2 + psi_dot**2) + abs(u)
        assert abs(walker) <= 1e-12 * scale
        assert abs(swing_leg) <= 1e-12 * scale


def test_an_input_along_a_stray_symbol_is_refused():
    """``along`` may use the phase's coordinates and the model's parameters only."""
    from derive.engine.hybrid import hybrid_quantities

    stray = sm.Symbol("kappa", real=True)
    phase = dataclasses.replace(
        compass_gait.STANCE, inputs=(Input("u", compass_gait.theta - stray, "hip"),)
    )
    model = dataclasses.replace(compass_gait.MODEL, phases=(phase,))
    with pytest.raises(ValueError, match="kappa is no coordinate of the phase and no parameter"):
        hybrid_quantities(model)
