"""CasADi rootfinders for the fixed point q^f of the ILE stride map: a test oracle.

The runtime answers q^f from the closed form (10) (:mod:`vsw.models.ile.analysis`) and
every model's gaits from :mod:`vsw.gaits.search`; these rootfinders are a third, independent
route the tests (tests/test_fixed_point.py) and benchmark case 3 compare with.

Two maps, one rootfinder (CasADi ``newton``):

``'closed-form'``
    The generated closed-form stride map, eq. (9) (``generated.ile.stride_map`` called on
    CasADi SX symbols).
``'integrated'``
    A stride map built by *numerically integrating* the swing-phase equations of motion
    (eq. 2 and 4) with a fixed-step 8th-order Runge-Kutta method (Dormand-Prince, 12
    stages) written as one CasADi SX graph, independent of the energy integrals.
    The angle theta is the independent variable, so both phase ends are known angles
    (theta_I -> theta_II, theta_II -> theta_IV; geometry from ``generated.ile``) and no
    event detection is needed inside CasADi::

        d (omega**2) / d theta = 2 theta'' = 2 swing_acceleration(theta, rho),
        d tau / d theta = 1 / omega.

    This requires omega > 0 throughout (the walker gets over the apex); below that the
    integration fails and the solve reports non-convergence. Lift-off is not checked here
    (that is the simulation's and the analysis' job).

Every result is checked independently of what CasADi reports: a solve counts as converged
only when the returned q is finite and the residual |f(q) - q|, re-evaluated outside the
solver, is at most ``tol * max(1, |q|)`` (CasADi 3.8's ``newton`` can return NaN while
reporting success).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np

from generated import ile
from generated.ile.params import PARAMETERS
from vsw.runtime.errors import ConvergenceError, VswInputError

__all__ = [
    "METHODS",
    "BatchFixedPointResult",
    "FixedPointResult",
    "integrated_stride_map",
    "solve_fixed_point",
    "solve_fixed_point_batch",
]

METHODS = ("closed-form", "integrated")

#: Residual tolerance (relative to max(1, |q|)) for a solve to count as converged.
DEFAULT_TOL = 1e-12


@dataclass(frozen=True)
class FixedPointResult:
    """Result of one fixed-point solve.

    Attributes
    ----------
    q_fixed : float
        The fixed point q^f = omega_I**2 at the Poincaré section.
    residual : float
        f(q_fixed) - q_fixed, re-evaluated after the solve.
    converged : bool
        Finite q with |residual| <= tol * max(1, |q|) (always True when returned by
        :func:`solve_fixed_point`, which raises otherwise).
    iterations : int
        Newton iterations CasADi reports.
    method : str
        ``'closed-form'`` or ``'integrated'``.
    stats : dict
        CasADi's solver statistics (``return_status``, ``success``, timings ...).
    """

    q_fixed: float
    residual: float
    converged: bool
    iterations: int
    method: str
    stats: dict


@dataclass(frozen=True)
class BatchFixedPointResult:
    """Result of :func:`solve_fixed_point_batch`: arrays over the parameter sets.

    Attributes
    ----------
    q_fixed, residual : numpy.ndarray
        Fixed points (NaN where a solve failed) and re-evaluated residuals.
    converged : numpy.ndarray of bool
    method : str
    """

    q_fixed: np.ndarray
    residual: np.ndarray
    converged: np.ndarray
    method: str


def _validate_arrays(beta, theta_II, phi0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Broadcast and check parameters against the generated table (one-line errors)."""
    try:
        arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (beta, theta_II, phi0)))
    except (TypeError, ValueError) as exc:
        raise VswInputError(f"parameters must be real numbers or arrays: {exc}") from None
    for p, a in zip(PARAMETERS, arrays):
        bad = ~(np.isfinite(a) & (a > p.lower) & (a < p.upper))
        if bad.any():
            v = a[bad].flat[0]
            raise VswInputError(f"{p.name} = {v!r} is out of range: {p.reason}")
    return tuple(np.ravel(a) for a in arrays)  # type: ignore[return-value]


def _check_method(method: str) -> str:
    if method not in METHODS:
        raise VswInputError(f"method = {method!r} must be one of {', '.join(METHODS)}")
    return method


#: Round-off slack (radians) when checking that the phases run forward.
_ANGLE_SLACK = 1e-12

#: Fixed steps per swing phase of the 8th-order Runge-Kutta integration.
RK_STEPS = 32


def _rk8_phase(theta_a, theta_b, leg_ratio, u_a, n_steps: int):
    """Integrate one swing phase from theta_a to theta_b with theta as the variable.

    The explicit 12-stage, 8th-order Runge-Kutta method of Dormand and Prince (the one
    behind DOP853; coefficients from SciPy) with ``n_steps`` fixed steps, built as one
    CasADi SX graph so Newton gets exact derivatives. The state is (u, tau) with
    u = omega**2; eq. (2)/(4), theta'' = a(theta), becomes with theta as the variable::

        d u / d theta = 2 a(theta) = 2 swing_acceleration(theta, rho),
        d tau / d theta = 1 / sqrt(u).

    u rather than omega is integrated because omega ~ |theta| near a grazing apex, a kink
    that costs a fixed-step method its order; u stays smooth. tau keeps the 1/sqrt(u)
    singularity of a grazing apex and is a by-product (the map only needs u).

    Returns
    -------
    tuple
        (u_b, tau_b - tau_a, min u over all stages): the last rejects integrations through
        u = 0 (a fall back), which fixed steps would otherwise step across.
    """
    import casadi as ca
    from scipy.integrate._ivp import dop853_coefficients as rk

    a_coef, b_coef, c_coef = rk.A[: rk.N_STAGES, : rk.N_STAGES], rk.B, rk.C[: rk.N_STAGES]
    h = (theta_b - theta_a) / n_steps
    u, tau = u_a, 0
    u_min = u_a
    for i in range(n_steps):
        theta = theta_a + i * h
        k_u, k_tau = [], []
        for s in range(rk.N_STAGES):
            w = u + h * sum(float(a_coef[s, j]) * k_u[j] for j in range(s) if a_coef[s, j])
            u_min = ca.fmin(u_min, w)
            th = theta + float(c_coef[s]) * h
            k_u.append(2 * ile.swing_acceleration(th, leg_ratio))
            k_tau.append(1 / ca.sqrt(w))
        u = u + h * sum(float(b_coef[s]) * k_u[s] for s in range(rk.N_STAGES) if b_coef[s])
        tau = tau + h * sum(float(b_coef[s]) * k_tau[s] for s in range(rk.N_STAGES) if b_coef[s])
        u_min = ca.fmin(u_min, u)
    return u, tau, u_min


@cache
def _integrated_map_function(n_steps: int = RK_STEPS) -> Any:
    """CasADi Function ``(q, [beta, theta_II, phi0]) -> (q_next, tau_I_II, tau_III_IV)``.

    Outputs are NaN when omega does not stay positive (the walker falls back).
    """
    import casadi as ca

    q = ca.SX.sym("q")
    par = ca.SX.sym("par", 3)
    beta, theta_II, phi0 = par[0], par[1], par[2]
    # Phase end angles are known: no event detection needed (guard of eq. 5 solved).
    th_I = ile.theta_I(beta, phi0)
    th_IV = ile.theta_IV(beta, phi0)
    u_II, tau_1, min_1 = _rk8_phase(th_I, theta_II, beta, q, n_steps)
    omega_III = ile.extension_reset(beta, ca.sqrt(u_II))
    u_IV, tau_2, min_2 = _rk8_phase(theta_II, th_IV, 1, omega_III**2, n_steps)
    omega_I_next = ile.heelstrike_reset(beta, phi0, ca.sqrt(u_IV))
    # Valid only if omega > 0 throughout and the phases run forward (theta_I <= theta_II
    # <= theta_IV, up to _ANGLE_SLACK so that a theta_II on an edge, equal to theta_I in
    # round-off, still counts); otherwise NaN, so the solve fails the residual check.
    valid = ca.logic_and(
        ca.logic_and(ca.fmin(min_1, min_2) > 0, q > 0),
        ca.logic_and(theta_II >= th_I - _ANGLE_SLACK, theta_II <= th_IV + _ANGLE_SLACK),
    )
    nan = ca.SX(math.nan)
    outs = [ca.if_else(valid, v, nan) for v in (omega_I_next**2, tau_1, tau_2)]
    return ca.Function(
        "ile_integrated_map", [q, par], outs, ["q", "par"], ["q_next", "tau_I_II", "tau_III_IV"]
    )


def integrated_stride_map(
    beta: float, theta_II: float, phi0: float, q: float
) -> tuple[float, float, float]:
    """Stride map by 8th-order Runge-Kutta integration of eq. (2) and (4), plus durations.

    Parameters
    ----------
    beta, theta_II, phi0 : float
        Model parameters (radians); theta_I < theta_II < theta_IV is assumed.
    q : float
        q at the Poincaré section (instant I).

    Returns
    -------
    tuple of float
        ``(q_next, tau_I_II, tau_III_IV)``; NaN when the walker does not get over the apex.
    """
    out = _integrated_map_function()(q, [beta, theta_II, phi0])
    return tuple(float(v) for v in out)  # type: ignore[return-value]


@cache
def _rootfinder(method: str, max_iter: int) -> tuple[Any, Any]:
    """(rootfinder, residual function) for a method; both take (q, [beta, theta_II, phi0])."""
    import casadi as ca

    opts = {
        "abstol": 1e-15,
        "max_iter": max_iter,
        "error_on_fail": False,
        # NaN from a fall back is expected and reported via the residual check instead.
        "show_eval_warnings": False,
    }
    if method == "closed-form":
        q = ca.SX.sym("q")
        par = ca.SX.sym("par", 3)
        g = ile.stride_map(par[0], par[1], par[2], q) - q
    else:
        q = ca.SX.sym("q")
        par = ca.SX.sym("par", 3)
        g = _integrated_map_function()(q, par)[0] - q
    residual = ca.Function("residual", [q, par], [g])
    rf = ca.rootfinder(f"ile_fixed_point_{method.replace('-', '_')}", "newton", residual, opts)
    return rf, residual


def _default_q0(method: str, beta: np.ndarray) -> np.ndarray:
    """Initial guess: for the integrated map one that certainly gets over the apex.

    omega**2 drops by at most 2 / beta over the short-leg phase and needs at most 2 / beta**4
    at instant II to carry the extended leg over the apex (extension multiplies omega by
    beta**2), so q0 = 4 / beta**4 + 4 / beta keeps omega > 0 throughout. The map is
    (mathematically) linear in q, so Newton needs only a couple of iterations from there.
    """
    if method == "closed-form":
        return np.ones_like(beta)
    return 4.0 / beta**4 + 4.0 / beta


def _residual_numpy(method: str, residual_fn: Any, q: np.ndarray, par: np.ndarray) -> np.ndarray:
    """Residual f(q) - q re-evaluated outside the rootfinder."""
    if method == "closed-form":
        # The numpy backend of the generated code: independent of the CasADi graph.
        return ile.stride_map(par[0], par[1], par[2], q) - q
    return np.array(residual_fn.map(q.size)(q[None, :], par), dtype=float).ravel()


def _converged(q: np.ndarray, res: np.ndarray, tol: float) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return np.isfinite(q) & np.isfinite(res) & (np.abs(res) <= tol * np.maximum(1.0, np.abs(q)))


def solve_fixed_point(
    beta: float,
    theta_II: float,
    phi0: float,
    method: str = "closed-form",
    q0: float | None = None,
    *,
    tol: float = DEFAULT_TOL,
    max_iter: int = 50,
) -> FixedPointResult:
    """Solve f(q) = q with CasADi's Newton rootfinder.

    Parameters
    ----------
    beta, theta_II, phi0 : float
        Model parameters (radians).
    method : {'closed-form', 'integrated'}
        Which stride map to solve (see the module docstring).
    q0 : float, optional
        Initial guess; default 1 (closed form) or a value that gets over the apex
        (integrated).
    tol : float
        Converged when |f(q) - q| <= tol * max(1, |q|).
    max_iter : int
        Newton iteration limit.

    Returns
    -------
    FixedPointResult

    Raises
    ------
    vsw.runtime.errors.VswInputError
        Out-of-domain parameters or unknown method.
    vsw.runtime.errors.ConvergenceError
        The solve did not converge or returned a non-finite value (one-line message).
    """
    method = _check_method(method)
    b, t2, p0 = _validate_arrays(beta, theta_II, phi0)
    if b.size != 1:
        raise VswInputError(
            "solve_fixed_point takes scalars; use solve_fixed_point_batch for arrays"
        )
    if q0 is None:
        q_start = float(_default_q0(method, b)[0])
    else:
        q_start = float(q0)
        if not math.isfinite(q_start):
            raise VswInputError(f"q0 = {q0!r} must be finite")
    rf, residual_fn = _rootfinder(method, int(max_iter))
    par = np.array([b[0], t2[0], p0[0]])
    q = float(rf(q_start, par))
    stats = dict(rf.stats())
    res = float(_residual_numpy(method, residual_fn, np.array([q]), par[:, None])[0])
    ok = bool(_converged(np.array([q]), np.array([res]), tol)[0])
    if not ok:
        raise ConvergenceError(
            f"fixed point ({method}) did not converge for beta={b[0]!r}, theta_II={t2[0]!r}, "
            f"phi0={p0[0]!r}: q={q!r}, residual={res!r}, casadi status "
            f"{stats.get('return_status')!r}"
        )
    return FixedPointResult(
        q_fixed=q,
        residual=res,
        converged=True,
        iterations=int(stats.get("iter_count", -1)),
        method=method,
        stats=stats,
    )


def solve_fixed_point_batch(
    beta,
    theta_II,
    phi0,
    method: str = "closed-form",
    q0=None,
    *,
    tol: float = DEFAULT_TOL,
    max_iter: int = 50,
    parallelization: str = "serial",
    threads: int = 2,
) -> BatchFixedPointResult:
    """Solve the fixed point for many parameter sets at once (``casadi.Function.map``).

    Parameters
    ----------
    beta, theta_II, phi0 : array_like
        Broadcast against each other; the result is flat in their broadcast order.
    method : {'closed-form', 'integrated'}
    q0 : array_like, optional
        Initial guesses (broadcast); default as in :func:`solve_fixed_point`.
    tol, max_iter : float, int
        As in :func:`solve_fixed_point`.
    parallelization : {'serial', 'thread', 'openmp'}
        Passed to ``Function.map``; ``'thread'`` uses ``threads`` threads.

    Returns
    -------
    BatchFixedPointResult
        Failed solves have ``converged=False`` and ``q_fixed=NaN``; nothing is raised for
        them.
    """
    method = _check_method(method)
    b, t2, p0 = _validate_arrays(beta, theta_II, phi0)
    n = b.size
    if n == 0:
        empty = np.empty(0)
        return BatchFixedPointResult(empty, empty.copy(), np.empty(0, dtype=bool), method)
    if q0 is None:
        q_start = _default_q0(method, b)
    else:
        q_start = np.broadcast_to(np.asarray(q0, dtype=float), b.shape).ravel()
    rf, residual_fn = _rootfinder(method, int(max_iter))
    par = np.vstack([b, t2, p0])
    mapped = (
        rf.map(n, parallelization, threads)
        if parallelization == "thread"
        else rf.map(n, parallelization)
    )
    q = np.array(mapped(q_start[None, :], par), dtype=float).ravel()
    res = _residual_numpy(method, residual_fn, q, par)
    ok = _converged(q, res, tol)
    return BatchFixedPointResult(
        q_fixed=np.where(ok, q, np.nan), residual=res, converged=ok, method=method
    )
