"""The route a user would write without ``vsw optimize``: single shooting with SciPy's SLSQP
on the simulated step. Benchmark case 16 (benchmarks/run.py) runs
:func:`compass_push_off_by_shooting`, the compass gait on level ground powered by its
push-off; the others are not cases (their SLSQP runs do not converge).

:func:`least_work_by_shooting`'s problem is the point-mass biped's least-work gait on
level ground with Srinivasan & Ruina's actuators (``vsw optimize --model point-mass-biped
--minimize work --target-speed V --use leg_force --use push_off --use heel_strike``): the
unknowns are the state just after the step (its height and rates: the section fixes ``x =
-d / 2``), the leg force at ``KNOTS`` equally spaced times of the step (linear between
them, the step's duration ``d / V`` set by the target), and the push-off and heel-strike
impulses. The step is simulated (SciPy's DOP853, 1e-10) with the generated accelerations
and input gains; the constraints are the step event at the end (``x = d / 2``),
periodicity through the generated impulse gains and reset, the leg at most ``l`` and ``F,
impulses >= 0``; the cost is the positive work (the leg force's power's positive part on a
fine grid of the dense output, the impulses' work). SLSQP's gradients are finite
differences, as a user's would be. Its start is better than the collocation's (the leg at
full length, the inverted pendulum's speed, the weight as the force): a kindness to the
peer.

``python benchmarks/powered_peer.py [V]`` runs both once, side by side, and prints their
costs and times (docs/models/powered_walking.md).
:func:`kuo_least_work_by_shooting` is the same route on the Kuo walker.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize

import generated.point_mass_biped as pmb
from vsw.models import load
from vsw.synthesis.powered import Request, optimize

KNOTS = 12
SAMPLES = 400
"""Points of the dense output the leg force's positive work and the leg length are taken on."""


@dataclass
class ShootingResult:
    cost: float
    success: bool
    message: str
    iterations: int
    evaluations: int
    seconds: float


def _step(params: tuple[float, ...], z: np.ndarray, duration: float):
    """The simulated step from the unknowns: the dense solution and the force schedule."""
    d = params[3]
    y0, xd0, yd0 = z[:3]
    forces = z[3 : 3 + KNOTS]
    times = np.linspace(0.0, duration, KNOTS)

    def rhs(t: float, s: np.ndarray) -> np.ndarray:
        force = np.interp(t, times, forces)
        acc = np.array(pmb.stance_accelerations(*params, *s), dtype=float)
        gains = np.array(pmb.stance_input_gains(*params, *s), dtype=float).reshape(2, 2)
        return np.array([s[2], s[3], *(acc + gains[:, 0] * force)])

    start = np.array([-d / 2, y0, xd0, yd0])
    solution = solve_ivp(rhs, (0.0, duration), start, method="DOP853", rtol=1e-10,
                         atol=1e-10, dense_output=True)  # fmt: skip
    return solution, times, forces, start


def _after_step(params: tuple[float, ...], end: np.ndarray, push: float,
                heel: float) -> tuple[np.ndarray, float]:  # fmt: skip
    """The state after the push-off, the reset and the heel-strike, and the push-off's work."""

    def leg_rate(s: np.ndarray) -> float:
        return float(pmb.event_heelstrike_impulse_rates_before(*params, *s)[0])

    gains = np.array(pmb.event_heelstrike_impulse_gains_before(*params, *end), dtype=float)
    pushed = end.copy()
    pushed[2:] += gains * push
    work = push * (leg_rate(end) + leg_rate(pushed)) / 2
    after = np.array(pmb.event_heelstrike_reset(*params, *pushed), dtype=float)
    gains = np.array(pmb.event_heelstrike_impulse_gains_after(*params, *after), dtype=float)
    after[2:] += gains.reshape(2, -1)[:, 0] * heel
    return after, work


def least_work_by_shooting(speed: float, params: tuple[float, ...],
                           maxiter: int = 300) -> ShootingResult:  # fmt: skip
    """SLSQP on the simulated step (module docstring)."""
    m, g, l, d, _shortest = params
    duration = d / speed
    grid = np.linspace(0.0, duration, SAMPLES)
    cache: dict[bytes, tuple] = {}

    def evaluate(z: np.ndarray) -> tuple:
        key = z.tobytes()
        if key not in cache:
            solution, times, forces, start = _step(params, z, duration)
            states = solution.sol(grid)
            legs = np.hypot(states[0], states[1])
            rates = (states[0] * states[2] + states[1] * states[3]) / legs
            power = np.interp(grid, times, forces) * rates
            work = np.trapezoid(np.maximum(power, 0.0), grid)
            end = solution.y[:, -1]
            after, push_work = _after_step(params, end, z[-2], z[-1])
            cache.clear()
            cache[key] = (work + max(push_work, 0.0), end, after, start, legs)
        return cache[key]

    def cost(z: np.ndarray) -> float:
        return evaluate(z)[0]

    def equalities(z: np.ndarray) -> np.ndarray:
        _, end, after, start, _ = evaluate(z)
        return np.array([end[0] - d / 2, *(after[1:] - start[1:])])

    def inequalities(z: np.ndarray) -> np.ndarray:
        return l - evaluate(z)[4][::8]

    alpha = math.asin(d / (2 * l))
    guess = np.concatenate([[l * math.cos(alpha), speed, 0.0], np.full(KNOTS, m * g),
                            [0.1, 0.1]])  # fmt: skip
    bounds = [(0.3 * l, l), (0.0, None), (None, None), *([(0.0, None)] * KNOTS),
              (0.0, None), (0.0, None)]  # fmt: skip
    began = time.perf_counter()
    result = minimize(cost, guess, method="SLSQP", bounds=bounds,
                      constraints=[{"type": "eq", "fun": equalities},
                                   {"type": "ineq", "fun": inequalities}],
                      options={"maxiter": maxiter, "ftol": 1e-10})  # fmt: skip
    seconds = time.perf_counter() - began
    violation = float(np.max(np.abs(equalities(result.x))))
    held = violation <= 1e-6 and float(np.min(inequalities(result.x))) >= -1e-6
    return ShootingResult(
        float(result.fun),
        bool(result.success and held),
        f"{result.message} (equalities held to {violation:.1g})",
        int(result.nit),
        int(result.nfev),
        seconds,
    )


def kuo_least_work_by_shooting(speed: float, params: tuple[float, ...], knots: int = KNOTS,
                               maxiter: int = 300) -> ShootingResult:  # fmt: skip
    """SLSQP single shooting on the Kuo walker (benchmark case 16): the unknowns are the
    stance rate just after heelstrike (the section fixes the angle at -alpha), the stance
    torque at ``knots`` equally spaced times of the step (linear between them; the step's
    duration ``d / V`` set by the target) and the push-off. The step is simulated (SciPy's
    DOP853, 1e-10) with the generated accelerations and input gain; the constraints are
    the step event at the end (the legs at +alpha) and periodicity through the generated
    reset and push-off gain; the push-off ``>= 0``. The cost is the positive work: the
    torque's power's positive part on a fine grid of the dense output, and the push-off's
    ``c P^2 / 2``. Finite-difference gradients, as a user's would be."""
    import generated.kuo_walker as kuo

    _m, _g, l, d = params
    alpha = math.asin(d / (2 * l))
    duration = d / speed
    grid = np.linspace(0.0, duration, SAMPLES)
    times = np.linspace(0.0, duration, knots)
    cache: dict[bytes, tuple] = {}

    def evaluate(z: np.ndarray) -> tuple:
        key = z.tobytes()
        if key not in cache:
            torques = z[1 : 1 + knots]

            def rhs(t: float, s: np.ndarray) -> np.ndarray:
                (acc,) = kuo.stance_accelerations(*params, *s)
                (gain,) = kuo.stance_input_gains(*params, *s)
                return np.array([s[1], acc + gain * np.interp(t, times, torques)])

            solution = solve_ivp(rhs, (0.0, duration), np.array([-alpha, z[0]]),
                                 method="DOP853", rtol=1e-10, atol=1e-10,
                                 dense_output=True)  # fmt: skip
            states = solution.sol(grid)
            work = np.trapezoid(np.maximum(np.interp(grid, times, torques) * states[1], 0.0),
                                grid)  # fmt: skip
            end = solution.y[:, -1]
            after = np.array(kuo.event_heelstrike_reset(*params, *end), dtype=float)
            (gain,) = kuo.event_heelstrike_impulse_gains_with(*params, *end)
            after[1] += gain * z[-1]
            push_work = (
                float(kuo.event_heelstrike_impulse_work_with(*params, *end)) * z[-1] ** 2 / 2
            )
            cache.clear()
            cache[key] = (work + push_work, end, after)
        return cache[key]

    def equalities(z: np.ndarray) -> np.ndarray:
        _, end, after = evaluate(z)
        return np.array([end[0] - alpha, after[1] - z[0]])

    guess = np.concatenate([[speed / l], np.zeros(knots), [0.05]])
    bounds = [(1e-3, None), *([(None, None)] * knots), (0.0, None)]
    began = time.perf_counter()
    result = minimize(lambda z: evaluate(z)[0], guess, method="SLSQP", bounds=bounds,
                      constraints=[{"type": "eq", "fun": equalities}],
                      options={"maxiter": maxiter, "ftol": 1e-12})  # fmt: skip
    seconds = time.perf_counter() - began
    violation = float(np.max(np.abs(equalities(result.x))))
    return ShootingResult(float(result.fun), bool(result.success and violation <= 1e-8),
                          f"{result.message} (equalities held to {violation:.1g})",
                          int(result.nit), int(result.nfev), seconds)  # fmt: skip


def compass_push_off_by_shooting(step_length: float, params: tuple[float, ...],
                                 maxiter: int = 200) -> ShootingResult:  # fmt: skip
    """SLSQP single shooting on the compass gait on level ground powered by its push-off
    alone (benchmark case 16; ``vsw optimize --model level-compass-gait --minimize work
    --target-step-length S --use push_off``): the unknowns are the legs' rates just after
    heelstrike (the step length fixes the angles, ``theta = -psi = -asin(S / 2 (a + b))``)
    and the push-off. The step is simulated (SciPy's DOP853, 1e-10) with the generated
    accelerations to the heelstrike guard's crossing; the constraints are periodicity
    through the generated reset and push-off gain (the rates after the step, and the stance
    leg's angle: the step ends where the legs are at +-theta); the push-off ``>= 0``. The
    cost is the push-off's work ``c P^2 / 2``. Finite-difference gradients, as a user's
    would be; the start: both legs turning at 1 rad/s and a push-off of 1 N s."""
    import generated.level_compass_gait as lcg

    _m_h, _m, a, b, _g = params
    theta0 = -math.asin(step_length / (2 * (a + b)))
    cache: dict[bytes, tuple] = {}

    def rhs(_t: float, s: np.ndarray) -> np.ndarray:
        return np.array([s[2], s[3], *lcg.stance_accelerations(*params, *s)], dtype=float)

    def heelstrike(_t: float, s: np.ndarray) -> float:
        return float(lcg.event_heelstrike_guard(*params, *s))

    # Heelstrike counts past mid-stance (theta > 0, the model's `when`): the guard also
    # crosses as the swing foot leaves the ground and where it passes through it. So the
    # step is integrated to mid-stance, then to heelstrike, each stage ending at its event.
    def mid_stance(_t: float, s: np.ndarray) -> float:
        return float(s[0])

    mid_stance.terminal, mid_stance.direction = True, 1.0
    heelstrike.terminal, heelstrike.direction = True, 1.0

    def evaluate(z: np.ndarray) -> tuple:
        key = z.tobytes()
        if key not in cache:
            end = np.array([theta0, -theta0, z[0], z[1]])
            for event in (mid_stance, heelstrike):  # a stage without its event: no step
                stage = solve_ivp(rhs, (0.0, 3.0), end, method="DOP853", rtol=1e-10,
                                  atol=1e-10, events=event)  # fmt: skip
                end = stage.y[:, -1]
            after = np.array(lcg.event_heelstrike_reset(*params, *end), dtype=float)
            gains = np.array(lcg.event_heelstrike_impulse_gains_with(*params, *end), dtype=float)
            after[2:] += gains.reshape(2) * z[2]
            work = float(lcg.event_heelstrike_impulse_work_with(*params, *end)) * z[2] ** 2 / 2
            cache.clear()
            cache[key] = (work, np.array([after[0] - theta0, after[2] - z[0], after[3] - z[1]]))
        return cache[key]

    guess = np.array([1.0, 1.0, 1.0])
    bounds = [(None, None), (None, None), (0.0, None)]
    began = time.perf_counter()
    result = minimize(lambda z: evaluate(z)[0], guess, method="SLSQP", bounds=bounds,
                      constraints=[{"type": "eq", "fun": lambda z: evaluate(z)[1]}],
                      options={"maxiter": maxiter, "ftol": 1e-12})  # fmt: skip
    seconds = time.perf_counter() - began
    violation = float(np.max(np.abs(evaluate(result.x)[1])))
    return ShootingResult(float(result.fun), bool(result.success and violation <= 1e-8),
                          f"{result.message} (equalities held to {violation:.1g})",
                          int(result.nit), int(result.nfev), seconds)  # fmt: skip


def main(speed: float = 0.4) -> None:
    model = load("point_mass_biped")
    params = model.parameters()
    began = time.perf_counter()
    request = Request("work", target_speed=speed, use=("leg_force", "push_off", "heel_strike"))
    gait = optimize(model, params, request)
    print(f"collocation: {gait.status}, work {gait.cost:.6g} a step, "
          f"{time.perf_counter() - began:.1f} s")  # fmt: skip
    peer = least_work_by_shooting(speed, params)
    print(f"SLSQP single shooting: {'converged' if peer.success else 'not converged'} "
          f"({peer.message}), work {peer.cost:.6g}, {peer.iterations} iterations, "
          f"{peer.evaluations} evaluations, {peer.seconds:.1f} s")  # fmt: skip


if __name__ == "__main__":
    import sys

    main(*(float(a) for a in sys.argv[1:2]))
