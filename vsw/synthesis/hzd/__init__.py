"""Walking by hybrid zero dynamics (HZD): virtual constraints on a model with one degree of
underactuation, their restricted Poincaré map and the full-order closed loop.

:func:`analyze` takes a model (:func:`vsw.models.load`), a constraints file
(:mod:`derive.hzd`'s language; derived and cached by :mod:`vsw.synthesis.hzd.package`), parameters
and the controller's gains, and returns an :class:`HzdReport`: the zero dynamics' numbers
(:mod:`vsw.synthesis.hzd.zero`), the gait on the surface (its period, step, speed, feed-forward
torques, the actuators' work and the impact's loss), the impact invariance of the
constraints, and the full-order closed loop's fixed point and eigenvalues
(:mod:`vsw.synthesis.hzd.loop`, solved by :meth:`vsw.dynamics.hybrid.HybridModel.periodic_orbit`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.runtime.errors import ConvergenceError, ModelConditionError, VswInputError
from vsw.synthesis.hzd.loop import ClosedLoop
from vsw.synthesis.hzd.package import constraints_package
from vsw.synthesis.hzd.zero import Surface, ZeroDynamics, chebyshev_integral, zero_dynamics

__all__ = ["DEFAULT_GAINS", "HzdReport", "analyze", "invariant_alphas", "surface_of"]

LANDING_TOLERANCE = 1e-9
"""How far from zero the step event's guard may be on the surface at theta_minus (the
model's guard units: a foot height, or the sine of an angle)."""
DEFAULT_GAINS = (400.0, 40.0)
"""K_p (1/s^2) and K_d (1/s): y'' + 40 y' + 400 y = 0, a double pole at -20/s."""

SAMPLES = 401
"""Points of the step at which torques and the decoupling matrix are evaluated."""


def invariant_alphas(model: HybridModel, package: Any, params: Sequence[float],
                     given: Sequence[float] | None = None) -> list[float]:  # fmt: skip
    """The Bezier coefficients (the file's, or ``given``: every slot, those of
    impact-invariant outputs overwritten) with those the impact sets filled in (Westervelt et al.
    2003, Theorem 4's construction): ``alpha_0 = a(q_+)``, ``alpha_1 = alpha_0 +
    (theta_minus - theta_plus)/M * a'(q_+) q_+' / theta'(q_+)`` with ``(q_+, q_+')`` the
    impact of ``Phi(theta_minus)``, ``Phi'(theta_minus)`` (neither depends on alpha_0,
    alpha_1: a Bezier polynomial's end and slope at s = 1 are its last two)."""
    spec = package.HZD
    alphas = [0.0 if a is None else float(a) for a in spec["defaults"]]
    if given is not None:
        alphas = [float(a) for a in given]
    if not any(o["invariant"] for o in spec["layout"]):
        return alphas
    surface = Surface(package, params, alphas)
    q, dq, _ = surface.at(surface.theta_minus)
    after = model.reset(model.step_event["name"], params, np.concatenate([q, dq]))
    q_plus, qd_plus = after[: model.n], after[model.n :]
    theta_rate = float(surface.phase_row @ qd_plus)
    start = 0
    for k, out in enumerate(spec["layout"]):
        if out["invariant"]:
            degree = out["count"] - 1
            a0 = float(surface.controlled[k] @ q_plus + surface.offsets[k])
            slope = float(surface.controlled[k] @ qd_plus) / theta_rate
            alphas[start] = a0
            alphas[start + 1] = a0 + (surface.theta_minus - surface.theta_plus) / degree * slope
        start += out["count"]
    return alphas


def surface_of(model: HybridModel, package: Any, params: Sequence[float],
               given: Sequence[float] | None = None) -> Surface:  # fmt: skip
    """The constraint surface at ``params``, the impact's coefficients filled in, and its
    phase checked against the impact (the phase just after the impact from theta_minus must
    be theta_plus)."""
    surface = Surface(package, params, invariant_alphas(model, package, params, given))
    q, dq, _ = surface.at(surface.theta_minus)
    event = model.step_event["name"]
    landing = model.guard(event, params, np.concatenate([q, dq]))
    if not abs(landing) <= LANDING_TOLERANCE:
        raise VswInputError(
            f"the step does not end at theta_minus = {surface.theta_minus:.9g}: the "
            f"{event} guard there is {landing:.3g}, not 0 (the swing foot is not on the ground "
            "on the surface)"
        )
    after = model.reset(event, params, np.concatenate([q, dq]))
    theta = surface.phase(after[: model.n])
    if not abs(theta - surface.theta_plus) <= 1e-9 * max(1.0, abs(theta)):
        raise VswInputError(
            f"the constraints' theta_plus ({surface.theta_plus:.9g}) is not the phase after "
            f"the impact from theta_minus ({theta:.9g})"
        )
    # An impact moves no coordinate: the configuration after it must be on the surface
    # (outputs zero), or no rate can put the walker back on it.
    off = surface.outputs(after[: model.n])
    if not np.max(np.abs(off), initial=0.0) <= 1e-9 * max(1.0, float(np.max(np.abs(q)))):
        k = int(np.argmax(np.abs(off)))
        raise VswInputError(
            f"the configuration after the impact is off the constraint surface: output "
            f"{list(package.HZD['outputs'])[k]} is {off[k]:.6g} at theta_plus (the outputs must "
            "vanish at both ends of the step)"
        )
    return surface


@dataclass
class HzdReport:
    """What ``vsw hzd`` reports (each number's unit in :meth:`units`)."""

    zero: ZeroDynamics
    step_length: float
    mismatch: list[float]
    output_names: list[str]
    work_per_step: float
    impact_loss: float
    surface_jump: float
    peak_torques: dict[str, float]
    input_names: list[str]
    full_order: Orbit | None
    full_order_error: str | None
    gains: tuple[float, float]
    samples: dict[str, Any] = field(repr=False, default_factory=dict)

    @property
    def speed(self) -> float:
        return self.step_length / self.zero.period

    def to_dict(self) -> dict[str, Any]:
        z = self.zero
        full = None
        if self.full_order is not None:
            o = self.full_order
            full = {
                "theta_dot_minus": self.samples["full_theta_dot_minus"],
                "period": o.period,
                "eigenvalues": [[float(e.real), float(e.imag)] for e in o.eigenvalues],
                "max_abs_eigenvalue": o.max_abs_eigenvalue,
                "state": o.state,
            }
        return {
            "delta": z.delta,
            "delta_squared": z.delta_squared,
            "V": z.v_minus,
            "V_max": z.v_max,
            "quadrature_error": z.quadrature_error,
            "zeta_star": z.zeta_star,
            "theta_dot_minus": z.theta_dot_minus,
            "theta_dot_plus": z.theta_dot_plus,
            "period": z.period,
            "step_length": self.step_length,
            "speed": self.speed,
            "impact_invariance": {
                "mismatch_per_rate": dict(zip(self.output_names, self.mismatch)),
                "invariant": bool(max(abs(v) for v in self.mismatch) <= 1e-9),
            },
            "work_per_step": self.work_per_step,
            "impact_loss": self.impact_loss,
            "surface_jump": self.surface_jump,
            "peak_torques": self.peak_torques,
            "gains": {"kp": self.gains[0], "kd": self.gains[1]},
            "full_order": full,
            "full_order_error": self.full_order_error,
        }

    @staticmethod
    def units(model: HybridModel, phase_unit: str) -> dict[str, Any]:
        u = model.units
        t, e = u["time"], u["energy"]
        momentum = f"{u['mass']} {u['length']}^2/{t}"
        rate = f"{phase_unit}/{t}"
        return {
            "delta": "1", "delta_squared": "1", "V": f"({momentum})^2",
            "V_max": f"({momentum})^2", "quadrature_error": f"({momentum})^2",
            "zeta_star": f"({momentum})^2", "theta_dot_minus": rate, "theta_dot_plus": rate,
            "period": t, "step_length": u["length"], "speed": f"{u['length']}/{t}",
            "impact_invariance": {"mismatch_per_rate": "1", "invariant": None},
            "work_per_step": e, "impact_loss": e, "surface_jump": e,
            "peak_torques": None,
            "gains": {"kp": f"1/{t}^2", "kd": f"1/{t}"},
            "full_order": {"theta_dot_minus": rate, "period": t, "eigenvalues": "1",
                           "max_abs_eigenvalue": "1"},
            "full_order_error": None,
        }  # fmt: skip


def _gait_on_surface(model: HybridModel, loop: ClosedLoop, z: ZeroDynamics, params) -> dict:
    """The torques, the actuators' work and the impact's loss along the gait on the
    surface (state (Phi, Phi' theta_dot), theta_dot from zeta)."""
    s = loop.surface
    phase = loop.phase
    lo, hi = s.theta_plus, s.theta_minus

    def state(theta: np.ndarray) -> np.ndarray:
        q, dq, _ = s.at(theta)
        inertia, _ = s.zero(theta)
        rate = np.sqrt(2.0 * z.zeta(theta)) / inertia
        return np.concatenate([q, dq * rate])

    def power_per_rate(theta: np.ndarray) -> np.ndarray:
        out = []
        for t in np.atleast_1d(theta):
            x = state(np.array(t))
            u = loop.torques(params, x)
            rates = getattr(model.module, f"{phase}_input_rates")(*params, *x)
            power = sum(float(a) * float(b) for a, b in zip(u, rates))
            out.append(power / float(s.phase_row @ x[s.n :]))  # d theta = theta_dot dt
        return np.array(out)

    work = float(chebyshev_integral(power_per_rate, lo, hi)(hi))
    grid = np.linspace(lo, hi, SAMPLES)
    states = np.array([state(np.array(t)) for t in grid])
    torques = np.array([[float(v) for v in loop.torques(params, x)] for x in states])
    # Singular where its least singular value is round-off of J's and B's sizes.
    ratios = []
    for x in states:
        _, b, jac, _ = loop.parts(params, x)
        jb = np.array(loop.decoupling(params, x), float)
        size = np.linalg.norm(np.array(jac, float), 2) * np.linalg.norm(np.array(b, float), 2)
        ratios.append(np.linalg.svd(jb, compute_uv=False)[-1] / size)
    if not min(ratios) > 1e-9:
        where = grid[int(np.argmin(ratios))]
        raise VswInputError(
            f"the decoupling matrix L_g L_f y is singular on the gait at theta "
            f"= {where:.6g}: the inputs cannot enforce the constraints there"
        )
    x_minus, x_plus_surface = states[-1], states[0]
    after = model.reset(model.step_event["name"], params, x_minus)
    energy = model.energy
    loss = energy(phase, params, x_minus) - energy(phase, params, after)
    jump = energy(phase, params, x_plus_surface) - energy(phase, params, after)
    return {"work": work, "loss": loss, "jump": jump, "grid": grid, "states": states,
            "torques": torques, "x_minus": x_minus, "after": after}  # fmt: skip


def analyze(
    model: HybridModel,
    model_key: str,
    constraints: str | Path,
    values: Mapping[str, float] | None = None,
    gains: tuple[float, float] = DEFAULT_GAINS,
    full_order: bool = True,
    alphas: Sequence[float] | None = None,
) -> HzdReport:
    """The HZD report of ``constraints`` on ``model`` (see the module docstring); with
    ``alphas``, every Bezier coefficient in place of the file's (:func:`invariant_alphas`)."""
    phase = model.step_event["target"]
    if not model.phases[model.phase_index[phase]].get("inputs"):
        raise VswInputError(f"{model.name} has no inputs: virtual constraints need actuators")
    package = constraints_package(constraints, model_key, model.module)
    spec = package.HZD
    if spec["coordinates"] != list(model.coordinates):
        raise VswInputError(f"the constraints were derived for {spec['model']}, whose "
                            f"coordinates are not {model.name}'s")  # fmt: skip
    params = model.parameters(values)
    surface = surface_of(model, package, params, alphas)
    z = zero_dynamics(surface)
    loop = ClosedLoop(model, surface, *gains)
    gait = _gait_on_surface(model, loop, z, params)
    q, dq, _ = surface.at(surface.theta_minus)
    unit = model.reset(model.step_event["name"], params, np.concatenate([q, dq]))
    mismatch = surface.output_rates(unit[: model.n], unit[model.n :])
    inputs = model.phases[model.phase_index[loop.phase]]["inputs"]
    names = [i["name"] for i in inputs]
    peaks = {n: float(np.max(np.abs(gait["torques"][:, k]))) for k, n in enumerate(names)}
    report = HzdReport(
        zero=z, step_length=float(model.step_length(params, gait["x_minus"])),
        mismatch=[float(v) for v in mismatch], output_names=list(spec["outputs"]),
        work_per_step=gait["work"], impact_loss=gait["loss"], surface_jump=gait["jump"],
        peak_torques=peaks, input_names=names, full_order=None, full_order_error=None,
        gains=(float(gains[0]), float(gains[1])), samples=gait,
    )  # fmt: skip
    report.samples["surface"] = surface
    if full_order:
        _full_order(report, loop, params)
    return report


def _full_order(report: HzdReport, loop: ClosedLoop, params: Sequence[float]) -> None:
    """The closed loop's period-one gait from the restricted map's, by the runtime's
    orbit solver (its Newton and monodromy), or why it was not found."""
    closed = loop.hybrid()
    start = report.samples["states"][0]
    try:
        orbit = closed.periodic_orbit(params, start, [report.zero.period])
    except (ConvergenceError, ModelConditionError) as exc:
        report.full_order_error = str(exc)
        return
    state = np.array(list(orbit.state.values()))
    result = closed.step(params, state)
    before = closed.step_events(params, state)[-1].state_before
    report.full_order = orbit
    report.samples["full_theta_dot_minus"] = float(loop.surface.phase_row @ before[loop.n :])
    report.samples["full_step"] = result
    if not math.isfinite(report.samples["full_theta_dot_minus"]):
        report.full_order_error = "the closed loop's gait is not finite"
