"""Time-domain simulation of the hybrid instantaneous-leg-extension (ILE) walker.

This module is the *independent* check of the closed-form analysis: it integrates the
swing-phase equations of motion (eq. 2 and 4 of the paper) in time with SciPy's DOP853,
locates the transition instants with event functions, and applies the algebraic resets
(eq. 3 and 6). It never uses the closed-form stride map, fixed point, energy integrals or
the q_apex/q_liftoff bounds; it only uses the model *primitives* from ``generated.ile``
(equations of motion, resets, heelstrike guard, normal force, heelstrike geometry).

Time is dimensionless, tau = t sqrt(g / r_e); lengths are in r_e; angles in radians.

Edge cases (documented decisions)
---------------------------------
- ``theta_II <= theta_I``: a step starts at theta_I moving forward, so the extension angle
  is never reached (condition ``extension_reached``, not in the paper). The model defines
  no motion for this case, so :func:`simulate` raises :class:`vsw.runtime.errors.VswInputError`.
- ``theta_II >= theta_IV``: the stance leg would have to extend after the heelstrike
  (condition ``extension_before_heelstrike``, exact form of eq. 17). Also undefined, also
  a :class:`~vsw.runtime.errors.VswInputError`.
- A fall back in either phase (omega reaches 0 before theta_II or before the heelstrike)
  ends the run with ``ended='fell-backward'``; so does a phase that stalls at the apex
  (no event within ``_PHASE_TIME_LIMIT``, possible only at the exact separatrix).
- The stance foot lifting off (normal force < 0), at the start of a phase or during it,
  ends the run with ``ended='lift-off'``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from generated import ile
from generated.ile.params import PARAMETERS
from vsw.runtime import limits
from vsw.runtime.errors import ConvergenceError, VswInputError

__all__ = [
    "SimulationResult",
    "StepOutcome",
    "fixed_point_by_simulation",
    "poincare_map",
    "poincare_step",
    "simulate",
    "simulate_cost",
]

#: Longest a single swing phase may take (dimensionless time). Away from the exact apex
#: separatrix a phase lasts a few units; deviations from the unstable apex equilibrium
#: grow like exp(tau / sqrt(beta)), so even a 1e-16 perturbation resolves within ~40.
_PHASE_TIME_LIMIT = 1.0e3

#: Dense-output samples added to each recorded phase (for smooth plots).
_DENSE_SAMPLES = 40

#: Relative accuracy the event refinement aims at (event times and states).
_EVENT_TOL = 1e-14

ENDED_VALUES = ("completed", "fell-backward", "lift-off")


@dataclass(frozen=True)
class SimulationResult:
    """Outcome of :func:`simulate`.

    Attributes
    ----------
    t, theta, omega : numpy.ndarray
        Trajectory samples (solver steps plus every event point); ``t`` is dimensionless
        time tau, continuous over the whole run. At a reset the pre- and post-reset states
        are both present, with the same ``t``.
    phase : numpy.ndarray of int
        1 for the short-leg phase I-II, 2 for the extended-leg phase III-IV.
    step : numpy.ndarray of int
        Step index (0-based) of each sample.
    q : numpy.ndarray
        q = omega_I**2 just after each heelstrike, starting with ``q0``; its length is the
        number of completed steps plus one.
    ended : str
        ``'completed'``, ``'fell-backward'`` or ``'lift-off'``.
    events : list of tuple
        ``(kind, t, theta, omega)`` with kind in ``'I'`` (start of a step, incl. t = 0),
        ``'II'`` (before extension), ``'III'`` (after extension), ``'IV'`` (before
        heelstrike).
    step_periods, step_lengths : numpy.ndarray
        Duration (tau) and foothold-to-foothold distance (r_e) of each completed step.
    """

    t: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    phase: np.ndarray
    step: np.ndarray
    q: np.ndarray
    ended: str
    events: list = field(default_factory=list)
    step_periods: np.ndarray = field(default_factory=lambda: np.empty(0))
    step_lengths: np.ndarray = field(default_factory=lambda: np.empty(0))


class StepOutcome(NamedTuple):
    """One step of the Poincaré map: ``q_next`` is NaN unless ``ended == 'completed'``."""

    q_next: float
    ended: str


class _PhaseEnd(NamedTuple):
    kind: str  # 'guard' (extension / heelstrike), 'fell-backward' or 'lift-off'
    t: float
    theta: float
    omega: float
    ts: np.ndarray
    ys: np.ndarray


def _check_parameters(beta: float, theta_II: float, phi0: float) -> tuple[float, float, float]:
    """Validate the parameters against the generated table; one-line errors."""
    values = {"beta": beta, "theta_II": theta_II, "phi0": phi0}
    out = []
    for p in PARAMETERS:
        v = values[p.name]
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise VswInputError(f"{p.name} must be a real number, got {v!r}")
        v = float(v)
        if not math.isfinite(v) or not (p.lower < v < p.upper):
            raise VswInputError(f"{p.name} = {v!r} is out of range: {p.reason}")
        out.append(v)
    beta, theta_II, phi0 = out
    # phi0 below ~1e-308 overflows (beta - cos phi0) / sin phi0 to inf: theta_I = pi/2 is
    # still the right limit, and the checks below report it; no warning on the way.
    with np.errstate(over="ignore", divide="ignore"):
        th_I = float(ile.theta_I(beta, phi0))
        th_IV = float(ile.theta_IV(beta, phi0))
    if not theta_II > th_I:
        raise VswInputError(
            f"theta_II = {_angle(theta_II)} must exceed theta_I = {_angle(th_I)} (condition "
            "extension_reached): the stance leg never reaches the extension angle"
        )
    if not theta_II < th_IV:
        raise VswInputError(
            f"theta_II = {_angle(theta_II)} must be below theta_IV = {_angle(th_IV)} (condition "
            "extension_before_heelstrike, eq. (17) exact): the leg must extend before heelstrike"
        )
    return beta, theta_II, phi0


def _angle(radians: float) -> str:
    # Messages reach the command line, which speaks degrees.
    return f"{radians:.6g} rad ({math.degrees(radians):.6g} deg)"


def _check_q0(q0: float) -> float:
    if isinstance(q0, bool) or not isinstance(q0, (int, float, np.integer, np.floating)):
        raise VswInputError(f"q0 must be a real number, got {q0!r}")
    q0 = float(q0)
    if not (math.isfinite(q0) and q0 > 0):
        raise VswInputError(f"q0 = {q0!r} must be positive and finite: q = omega_I**2 > 0, eq. (8)")
    return q0


def _check_steps(steps: int) -> int:
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise VswInputError(f"steps = {steps!r} must be an integer >= 1")
    return int(steps)


def _refine_event(rhs, guard, guard_dot, t0: float, y0: np.ndarray, t_guess: float, rtol, atol):
    """Locate a guard root to ~machine precision by Newton on freshly integrated states.

    solve_ivp locates events on its dense-output interpolant, whose error is of the order
    of the local error. Here we re-integrate from the last accepted solver point ``t0``
    (an exact trajectory point, not an interpolated one) to the candidate time and apply
    Newton steps ``dt = -g / (dg/dt)``; every correction is a fresh short integration, so
    the final state satisfies the ODE to the integrator's tolerance and the guard to
    ~1e-15.
    """
    from scipy.integrate import solve_ivp

    def advance(t_from, y_from, t_to):
        if t_to == t_from:
            return np.array(y_from, dtype=float)
        sol = solve_ivp(rhs, (t_from, t_to), y_from, method="DOP853", rtol=rtol, atol=atol)
        return sol.y[:, -1]

    t, y = t_guess, advance(t0, y0, t_guess)
    for _ in range(8):
        g = guard(t, y)
        gd = guard_dot(y)
        if gd == 0 or not math.isfinite(gd):
            break
        dt = -g / gd
        if abs(dt) <= _EVENT_TOL * max(1.0, abs(t)):
            break
        y = advance(t, y, t + dt)
        t = t + dt
    return t, y


class _Swing(NamedTuple):
    """A swing phase's equation of motion, its fall and lift-off events (terminal, each
    with its time derivative for :func:`_refine_event`)."""

    rhs: Callable
    fall: Callable
    liftoff: Callable
    fall_dot: Callable
    liftoff_dot: Callable


def _swing(leg_ratio: float) -> _Swing:
    """The swing phase on a stance leg of ``leg_ratio`` r_e: eq. (2) or (4) and its events."""

    def rhs(_t, y):
        return (y[1], float(ile.swing_acceleration(y[0], leg_ratio)))

    def fall(_t, y):
        return y[1]

    fall.terminal, fall.direction = True, -1

    def liftoff(_t, y):
        return float(ile.normal_force(y[0], y[1], leg_ratio))

    liftoff.terminal, liftoff.direction = True, -1

    def fall_dot(y):
        return float(ile.swing_acceleration(y[0], leg_ratio))

    def liftoff_dot(y):
        # d/dt of N = cos^2 th - rho cos th w^2, by the chain rule (w' from the ODE).
        th, w = y
        wd = math.sin(th) / leg_ratio
        return -2 * math.cos(th) * math.sin(th) * w + leg_ratio * (
            math.sin(th) * w**3 - 2 * math.cos(th) * w * wd
        )

    return _Swing(rhs, fall, liftoff, fall_dot, liftoff_dot)


def _end_at_start(swing: _Swing, t_start: float, y_start: np.ndarray, guard) -> _PhaseEnd | None:
    """The phase's end at its very start, if it has one there (else None)."""
    # A phase that starts with the foot already pulled off the ground ends at once.
    if swing.liftoff(t_start, y_start) < 0:
        th0, w0 = float(y_start[0]), float(y_start[1])
        return _PhaseEnd("lift-off", t_start, th0, w0, np.array([t_start]), y_start[:, None])

    # A guard already met at the start (theta_II within round-off of theta_IV, so the
    # swing foot height is already <= 0) would never be crossed: the phase has length 0.
    g0 = guard(t_start, y_start)
    if (guard.direction > 0 and g0 >= 0) or (guard.direction < 0 and g0 <= 0):
        th0, w0 = float(y_start[0]), float(y_start[1])
        return _PhaseEnd("guard", t_start, th0, w0, np.array([t_start]), y_start[:, None])
    return None


def _integrate_phase(
    leg_ratio: float,
    t_start: float,
    y_start: np.ndarray,
    guard,
    guard_dot,
    rtol: float,
    atol: float,
    dense: bool = False,
) -> _PhaseEnd:
    """Integrate one swing phase from ``y_start`` until its guard, a fall or a lift-off.

    With ``dense``, ``_DENSE_SAMPLES`` evenly spaced samples from DOP853's 7th-order dense
    output are added to the solver's own (few, long) steps so plots of the trajectory
    are smooth.
    """
    from scipy.integrate import solve_ivp

    swing = _swing(leg_ratio)
    at_start = _end_at_start(swing, t_start, y_start, guard)
    if at_start is not None:
        return at_start

    events = [guard, swing.fall, swing.liftoff]
    sol = solve_ivp(
        swing.rhs,
        (t_start, t_start + _PHASE_TIME_LIMIT),
        y_start,
        method="DOP853",
        rtol=rtol,
        atol=atol,
        events=events,
        dense_output=dense,
    )
    if sol.status < 0:
        raise ConvergenceError(f"DOP853 failed at tau = {sol.t[-1]!r}: {sol.message}")
    hits = [(te[0], i) for i, te in enumerate(sol.t_events) if len(te)]
    if not hits:
        # Stalled on the apex separatrix: the walker does not get over the apex.
        t_end, (th_end, w_end) = float(sol.t[-1]), sol.y[:, -1]
        return _PhaseEnd("fell-backward", t_end, float(th_end), float(w_end), sol.t, sol.y)
    t_hit, i_hit = min(hits)
    derivs = [guard_dot, swing.fall_dot, swing.liftoff_dot]
    return _refined_end(sol, swing.rhs, events[i_hit], derivs[i_hit], t_hit, i_hit, t_start,
                        rtol, atol, dense)  # fmt: skip


def _refined_end(
    sol: Any,
    rhs: Callable,
    event: Callable,
    event_dot: Callable,
    t_hit: float,
    i_hit: int,
    t_start: float,
    rtol: float,
    atol: float,
    dense: bool,
) -> _PhaseEnd:
    """The phase's end at the event ``i_hit`` the solver found near ``t_hit``, located to
    machine precision, with the samples up to it (and the dense ones with ``dense``)."""
    kinds = ["guard", "fell-backward", "lift-off"]
    # Last accepted step before the event: an exact trajectory point for the refinement.
    k = int(np.searchsorted(sol.t, t_hit, side="right")) - 1
    k = max(0, min(k, len(sol.t) - 1))
    if sol.t[k] >= t_hit and k > 0:
        k -= 1
    t_ev, y_ev = _refine_event(rhs, event, event_dot, sol.t[k], sol.y[:, k], t_hit, rtol, atol)
    ts = np.append(sol.t[: k + 1], t_ev)
    ys = np.concatenate([sol.y[:, : k + 1], y_ev[:, None]], axis=1)
    if dense and sol.sol is not None:
        extra = np.linspace(t_start, float(t_ev), _DENSE_SAMPLES + 2)[1:-1]
        ts = np.concatenate([ts, extra])
        ys = np.concatenate([ys, sol.sol(extra)], axis=1)
        order = np.argsort(ts, kind="stable")
        ts, ys = ts[order], ys[:, order]
    return _PhaseEnd(kinds[i_hit], float(t_ev), float(y_ev[0]), float(y_ev[1]), ts, ys)


def simulate_cost(steps: int, record: bool = True) -> limits.Cost:
    """Estimated run time and peak memory of :func:`simulate` (see :mod:`vsw.runtime.limits`).

    Both grow linearly with the steps: every step keeps its q, period, length and four
    events, and with ``record`` its trajectory samples.
    """
    per_step = limits.SIMULATE_BYTES_PER_RECORDED_STEP if record else limits.SIMULATE_BYTES_PER_STEP
    return limits.Cost(
        steps * limits.SIMULATE_SECONDS_PER_STEP, limits.SIMULATE_BYTES_BASE + steps * per_step
    )


def simulate(
    beta: float,
    theta_II: float,
    phi0: float,
    q0: float,
    steps: int,
    *,
    rtol: float = 1e-12,
    atol: float = 1e-12,
    record: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> SimulationResult:
    """Simulate the hybrid ILE walker in time for up to ``steps`` steps.

    Each step starts at instant I, theta = theta_I (eq. 11) with omega = sqrt(q). Phase
    I-II integrates eq. (2) until theta = theta_II; the extension reset (eq. 3) gives
    omega_III; phase III-IV integrates eq. (4) until the swing foot touches the ground
    (guard of eq. 5); the heelstrike reset (eq. 6) and the leg swap start the next step
    at theta_IV - phi0. Every phase also watches for a fall back (omega = 0) and for the
    stance foot lifting off (normal force < 0).

    Parameters
    ----------
    beta, theta_II, phi0 : float
        Model parameters (radians); see ``generated.ile.params.PARAMETERS``. Additionally
        theta_I < theta_II < theta_IV is required (see the module notes).
    q0 : float
        q = omega_I**2 at the start, > 0.
    steps : int
        Number of steps to simulate, >= 1.
    rtol, atol : float
        DOP853 tolerances.
    record : bool
        Keep the trajectory samples (otherwise ``t``, ``theta``, ... hold only events).
    progress : callable, optional
        Called as ``progress(step_index, steps)`` after each completed step.

    Returns
    -------
    SimulationResult

    Raises
    ------
    vsw.runtime.errors.VswInputError
        Out-of-domain parameters, q0 or steps (one-line message), or more steps than
        fit the time and memory limits of :mod:`vsw.runtime.limits` (see :func:`simulate_cost`).
    vsw.runtime.errors.ConvergenceError
        The integrator itself failed (not expected for valid input).
    """
    beta, theta_II, phi0 = _check_parameters(beta, theta_II, phi0)
    q0 = _check_q0(q0)
    steps = _check_steps(steps)
    limits.check(f"simulating {steps} steps", simulate_cost(steps, record), "simulate fewer steps")
    walk = _Walk(beta, theta_II, phi0, rtol, atol, record, qs=[q0])
    # The new stance angle after heelstrike (eq. 11); the heelstrike itself is found by
    # the guard, and the post-impact angle is recomputed from it as theta_IV - phi0.
    walk.theta, walk.omega = float(ile.theta_I(beta, phi0)), math.sqrt(q0)
    for n in range(steps):
        if not walk.step(n):
            break
        if progress is not None:
            progress(n, steps)
    return walk.result(steps)


def _extension_guard(theta_II: float) -> tuple[Callable, Callable]:
    """Instant II's event, theta reaching theta_II, and its time derivative."""

    def ext_guard(_t, y):
        return y[0] - theta_II

    ext_guard.terminal, ext_guard.direction = True, 1

    def ext_dot(y):
        return y[1]

    return ext_guard, ext_dot


def _heelstrike_guard(beta: float, phi0: float) -> tuple[Callable, Callable]:
    """Instant IV's event, the swing foot reaching the ground (eq. 5), and its time
    derivative."""

    def hs_guard(_t, y):
        return float(ile.swing_foot_height(beta, phi0, y[0]))

    hs_guard.terminal, hs_guard.direction = True, -1

    def hs_dot(y):
        # d/dt of cos th - beta cos(phi0 - th).
        return (-math.sin(y[0]) - beta * math.sin(phi0 - y[0])) * y[1]

    return hs_guard, hs_dot


@dataclass
class _Walk:
    """A walk of :func:`simulate` as it goes: where it is, its samples, events and steps."""

    beta: float
    theta_II: float
    phi0: float
    rtol: float
    atol: float
    record: bool
    qs: list[float]
    t: float = 0.0
    theta: float = 0.0
    omega: float = 0.0
    ended: str = "completed"
    ts: list[np.ndarray] = field(default_factory=list)
    ths: list[np.ndarray] = field(default_factory=list)
    ws: list[np.ndarray] = field(default_factory=list)
    phases: list[np.ndarray] = field(default_factory=list)
    step_ids: list[np.ndarray] = field(default_factory=list)
    events: list[tuple[str, float, float, float]] = field(default_factory=list)
    periods: list[float] = field(default_factory=list)
    lengths: list[float] = field(default_factory=list)

    def keep(self, end: _PhaseEnd, phase: int, n: int) -> None:
        """Keep a phase's samples (with ``record``)."""
        if self.record:
            self.ts.append(end.ts)
            self.ths.append(end.ys[0])
            self.ws.append(end.ys[1])
            self.phases.append(np.full(end.ts.size, phase, dtype=int))
            self.step_ids.append(np.full(end.ts.size, n, dtype=int))

    def step(self, n: int) -> bool:
        """Walk step ``n`` from instant I; False when it fell or lifted off."""
        beta, theta_II, phi0, rtol, atol = self.beta, self.theta_II, self.phi0, self.rtol, self.atol
        t_I = self.t
        self.events.append(("I", self.t, self.theta, self.omega))
        ext_guard, ext_dot = _extension_guard(theta_II)
        end1 = _integrate_phase(beta, self.t, np.array([self.theta, self.omega]), ext_guard,
                                ext_dot, rtol, atol, self.record)  # fmt: skip
        self.keep(end1, 1, n)
        if end1.kind != "guard":
            self.ended = end1.kind
            return False
        # Instant II -> III: the event angle is theta_II by construction; snap to it so
        # the reset happens exactly there (the refinement leaves ~1e-16 of difference).
        self.events.append(("II", end1.t, theta_II, end1.omega))
        omega_III = float(ile.extension_reset(beta, end1.omega))
        self.events.append(("III", end1.t, theta_II, omega_III))
        hs_guard, hs_dot = _heelstrike_guard(beta, phi0)
        end2 = _integrate_phase(1.0, end1.t, np.array([theta_II, omega_III]), hs_guard, hs_dot,
                                rtol, atol, self.record)  # fmt: skip
        self.keep(end2, 2, n)
        if end2.kind != "guard":
            self.ended = end2.kind
            return False
        theta_IV, omega_IV = end2.theta, end2.omega
        self.events.append(("IV", end2.t, theta_IV, omega_IV))
        self.periods.append(end2.t - t_I)
        # Footholds: stance foot at the origin, swing foot at hip + beta (sin(phi0 - th),
        # -cos(phi0 - th)); the hip is at (sin th, cos th).
        self.lengths.append(math.sin(theta_IV) + beta * math.sin(phi0 - theta_IV))
        self.omega = float(ile.heelstrike_reset(beta, phi0, omega_IV))
        self.theta = theta_IV - phi0
        self.t = end2.t
        self.qs.append(self.omega * self.omega)
        return True

    def result(self, steps: int) -> SimulationResult:
        """The walk's :class:`SimulationResult` once it completed ``steps`` or ended."""
        if self.ended == "completed":
            self.events.append(("I", self.t, self.theta, self.omega))
        if self.record and self.ts:
            # The post-heelstrike state starts the next step; add it once at the very end
            # so the trajectory shows the final jump IV -> I.
            if self.ended == "completed":
                self.ts.append(np.array([self.t]))
                self.ths.append(np.array([self.theta]))
                self.ws.append(np.array([self.omega]))
                self.phases.append(np.array([1]))
                self.step_ids.append(np.array([steps]))
            t_arr, th_arr = np.concatenate(self.ts), np.concatenate(self.ths)
            w_arr, ph_arr = np.concatenate(self.ws), np.concatenate(self.phases)
            st_arr = np.concatenate(self.step_ids)
        else:
            events = self.events
            t_arr = np.array([e[1] for e in events])
            th_arr = np.array([e[2] for e in events])
            w_arr = np.array([e[3] for e in events])
            ph_arr = np.array([1 if e[0] in ("I", "II") else 2 for e in events], dtype=int)
            st_arr = np.cumsum([e[0] == "I" for e in events]).astype(int) - 1
        return SimulationResult(
            t=t_arr,
            theta=th_arr,
            omega=w_arr,
            phase=ph_arr,
            step=st_arr,
            q=np.array(self.qs),
            ended=self.ended,
            events=self.events,
            step_periods=np.array(self.periods),
            step_lengths=np.array(self.lengths),
        )


def poincare_step(beta: float, theta_II: float, phi0: float, q: float) -> StepOutcome:
    """One step of the simulated Poincaré map, with the way it ended.

    Returns
    -------
    StepOutcome
        ``q_next`` (NaN unless the step completed) and ``ended``.
    """
    res = simulate(beta, theta_II, phi0, q, 1, record=False)
    q_next = float(res.q[1]) if res.ended == "completed" else math.nan
    return StepOutcome(q_next, res.ended)


def poincare_map(beta: float, theta_II: float, phi0: float, q: float) -> float:
    """q just after the next heelstrike, by simulation; NaN if the step fails.

    Bad *inputs* (out-of-domain parameters, q <= 0) still raise ``VswInputError``; a
    physical failure (fall back, lift-off) returns NaN instead of raising.
    """
    return poincare_step(beta, theta_II, phi0, q).q_next


def fixed_point_by_simulation(
    beta: float,
    theta_II: float,
    phi0: float,
    *,
    q_grid: np.ndarray | None = None,
    xtol: float = 1e-15,
) -> float:
    """Fixed point of the simulated Poincaré map by bracketing and Brent's method.

    The baseline a researcher would write without the closed form; every evaluation of
    ``r(q) = poincare_map(q) - q`` is a one-step simulation:

    1. scan a logarithmic grid of q; if no step completes, scan linearly between the
       largest q that falls back and the smallest that lifts off (the feasible interval
       can be narrow);
    2. if r changes sign between two completed grid points, bracket there;
    3. otherwise, from the completed point with the smallest |r|, take secant steps
       q <- q + r / (1 - slope) with a finite-difference slope of the simulated map, and
       bracket around the estimate (widening by 10x) until r changes sign;
    4. refine the bracket with :func:`scipy.optimize.brentq`.

    Parameters
    ----------
    beta, theta_II, phi0 : float
        Model parameters (radians).
    q_grid : array_like, optional
        Trial q values for the bracket; default 10**linspace(-3, 3, 61).
    xtol : float
        Absolute tolerance for brentq (its relative tolerance is 4 machine epsilons).

    Returns
    -------
    float
        The fixed point q^f.

    Raises
    ------
    vsw.runtime.errors.ConvergenceError
        No fixed point among q values whose step completes (falls back or lifts off on
        the way, or no step completes at all).
    """
    from scipy.optimize import brentq

    _check_parameters(beta, theta_II, phi0)
    grid = np.logspace(-3, 3, 61) if q_grid is None else np.asarray(q_grid, dtype=float)
    where = f"beta={beta!r}, theta_II={theta_II!r}, phi0={phi0!r}"

    def residual(q: float) -> float:
        return poincare_map(beta, theta_II, phi0, q) - q

    def solve(a: float, b: float) -> float:
        return float(brentq(residual, a, b, xtol=xtol, rtol=4 * np.finfo(float).eps))

    done = _completed_residuals(beta, theta_II, phi0, grid)
    if not done:
        raise ConvergenceError(f"no step of the simulated map completes for {where}")
    found = _fixed_point_on_grid(done, solve)
    if found is None:
        found = _fixed_point_by_secant(done, residual, solve)
    if found is None:
        raise ConvergenceError(
            f"no fixed point of the simulated map for {where}: no sign change of f(q) - q "
            "between steps that complete"
        )
    return found


def _completed_residuals(
    beta: float, theta_II: float, phi0: float, grid: np.ndarray
) -> list[tuple[float, float]]:
    """(q, r(q)) for the q of ``grid`` whose step completes; when none does, for those of
    a linear scan between the largest q that falls back and the smallest that lifts off."""

    def scan(qs) -> list[tuple[float, float, str]]:
        out = []
        for q in qs:
            step = poincare_step(beta, theta_II, phi0, float(q))
            out.append((float(q), step.q_next - float(q), step.ended))
        return out

    points = scan(grid)
    if not any(e == "completed" for _, _, e in points):
        falls = [q for q, _, e in points if e == "fell-backward"]
        lifts = [q for q, _, e in points if e == "lift-off"]
        if falls and lifts and max(falls) < min(lifts):
            points = scan(np.linspace(max(falls), min(lifts), 42)[1:-1])
    return [(q, r) for q, r, e in points if e == "completed"]


def _fixed_point_on_grid(
    done: list[tuple[float, float]], solve: Callable[[float, float], float]
) -> float | None:
    """The fixed point where r changes sign (or is 0) between completed grid points."""
    for (qa, ra), (qb, rb) in itertools.pairwise(done):
        if ra == 0:
            return qa
        if (ra > 0) != (rb > 0):
            return solve(qa, qb)
    if done[-1][1] == 0:
        return done[-1][0]
    return None


def _fixed_point_by_secant(
    done: list[tuple[float, float]],
    residual: Callable[[float], float],
    solve: Callable[[float, float], float],
) -> float | None:
    """Secant steps from the completed point of smallest |r|, each bracketed by a widening
    interval until r changes sign; None when the steps leave the walking q."""
    q_a, r_a = min(done, key=lambda qr: abs(qr[1]))
    for _ in range(20):
        delta = 1e-6 * q_a
        r_d = residual(q_a + delta)
        if not math.isfinite(r_d):
            delta, r_d = -delta, residual(q_a - delta)
        slope = 1 + (r_d - r_a) / delta  # slope of the map itself
        if not (math.isfinite(slope) and slope != 1):
            break
        q_b = q_a + r_a / (1 - slope)
        if not (q_b > 0 and math.isfinite(q_b)):
            break
        r_b = residual(q_b)
        if not math.isfinite(r_b):
            break  # the estimate falls back or lifts off: no walking fixed point
        if r_b == 0:
            return q_b
        width = 1e-9 * q_b
        while width < q_b:
            lo, hi = q_b - width, q_b + width
            r_lo, r_hi = residual(lo), residual(hi)
            if math.isfinite(r_lo) and math.isfinite(r_hi) and (r_lo > 0) != (r_hi > 0):
                return solve(lo, hi)
            width *= 10
        q_a, r_a = q_b, r_b
    return None
