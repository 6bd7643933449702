"""Constrained design of ILE gait parameters with CasADi and IPOPT.

The inverse question of :mod:`vsw.models.ile.analysis`: which (beta, theta_II, phi0) give the gait a
user wants within what the robot can do. The NLP is built from the generated closed forms
(``generated.ile`` accepts CasADi SX), so every function and derivative is exact:

* objective: a weighted sum of ``-speed``, ``eigenvalue`` (eq. 19) and the cost of
  transport ``E_c(q^f) / (m g L)`` (eq. 20 per unit step length);
* equality targets: speed, q^f, step length, step frequency;
* inequalities: every *physical* existence condition in its exact form, the stance contact
  margin ``>= max(0, min_contact_margin)``, an eigenvalue upper bound, step length and step
  frequency bounds, bounds / fixed values of the decision variables; with
  ``conditions="paper"`` also (15) and (17) as the paper prints them.

Why the problem is split into regions
-------------------------------------
The exact apex margin (14) and the stance-contact margin are minima over the two swing
phases, each at the point of the phase nearest the apex, chosen by the signs of theta_I and
theta_II: they have kinks, and IPOPT, which needs twice-differentiable functions, stalls at
them (the failures of the first version of this module: 0 of 30 random feasible requests
converged). The derivation hands out the smooth pieces (``ile.condition_pieces``):

* the stance contact is exactly "N >= margin at instants I, II and IV" (N is convex in
  cos theta and rises towards the apex wherever N >= 0), three smooth rows everywhere;
* the apex margin is one smooth piece in each of three regions of the parameter space:
  theta_II <= 0 (the apex is crossed in phase III-IV), theta_I <= 0 <= theta_II (in phase
  I-II) and theta_I >= 0 (never crossed: q^f > 0 suffices).

Each region is a smooth NLP; a request is solved in every region that a scan finds
promising and the best verified solution wins.

Starts and verification
-----------------------
A deterministic low-discrepancy scan of the box (Halton points, the generated numpy code)
gives each region its best feasible points for the objective and its least-violating one;
IPOPT starts there. A solution counts only when IPOPT reports success *and* a numpy
re-evaluation of the closed forms confirms every constraint, with every physical condition
in its exact strict form; the design is then re-checked by the independent time-domain
simulation (:mod:`vsw.models.ile.simulate`).

Statuses
--------
``optimal``: a verified local optimum, the best over the regions and starts, that keeps
away from every open limit. ``not-attained``: the best design presses against an open
boundary (a strict condition, an open parameter limit such as beta < 1): the supremum or
infimum is a limit the model never reaches; the design is re-solved ever closer to it
(distances scaled by :data:`CONTINUATION`) to estimate the limiting value.
``infeasible``: neither the scan nor any solve found a point satisfying the constraints
(the constraints in conflict are named). ``not-converged``: the scan found feasible
points but no solve converged to a verified design.

``import vsw.models.ile.design`` is cheap: casadi is imported inside functions.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from generated import ile
from generated.ile.params import PARAMETERS
from vsw import stop
from vsw.errors import VswInputError
from vsw.models.ile.params import RobotScale, check_parameter
from vsw.quantities import maximised

__all__ = [
    "CONDITION_SETS",
    "CONTINUATION",
    "OBJECTIVES",
    "STATUSES",
    "STRICT_MARGIN",
    "TABLE_DISTANCE",
    "DesignResult",
    "design",
    "finite",
    "simulation_check",
]

STRICT_MARGIN = 1e-6
"""A strict condition ``margin > 0`` is imposed as ``margin >= STRICT_MARGIN``."""

TABLE_DISTANCE = 1e-3
"""Distance kept from the open limits of the parameter table (0 < beta < 1, ...)."""

CLOSED_MARGIN = 1e-9
"""The stance contact ``N >= 0`` is imposed as ``N >= CLOSED_MARGIN``: exactly at 0 the
verifying simulation would see a lift-off from round-off alone."""

CONTINUATION = (1.0, 10**-0.5, 1e-1, 10**-1.5, 1e-2)
"""Scales of the distances to the open limits, applied in turn when the optimum is not
attained: the objective at each gives the limiting value by extrapolation."""

OBJECTIVES = ("speed", "eigenvalue", "cost_of_transport")
"""Objective terms. The weighted sum minimised is
``-w_speed speed + w_eigenvalue eigenvalue + w_cot cost_of_transport``."""

CONDITION_SETS = ("exact", "paper")
"""``exact``: every physical existence condition in its exact form. ``paper``: in addition
(15) and (17) as printed (with (12)-(14), (16), which the exact set already holds)."""

STATUSES = ("optimal", "not-attained", "infeasible", "not-converged")
"""Outcomes of :func:`design`; the CLI exits 0 for the first two and 3 for the others."""

_OBJECTIVE_ALIASES = {
    "speed": {"speed": 1.0},
    "maximize_speed": {"speed": 1.0},
    "max_speed": {"speed": 1.0},
    "eigenvalue": {"eigenvalue": 1.0},
    "minimize_eigenvalue": {"eigenvalue": 1.0},
    "cost_of_transport": {"cost_of_transport": 1.0},
    "minimize_cost_of_transport": {"cost_of_transport": 1.0},
    "cot": {"cost_of_transport": 1.0},
}
_SIGN = {name: -1.0 if maximised(name) else 1.0 for name in OBJECTIVES}
"""An objective term's sign in the sum minimised, by its sense (:mod:`vsw.quantities`)."""

VARIABLES = ("beta", "theta_II", "phi0")
_TABLE = {p.name: (p.lower, p.upper) for p in PARAMETERS}
_CONDITION = {c[0]: c for c in ile.CONDITIONS}  # name -> (name, eq, strict, status, ...)
_MARGIN_NAMES = tuple(c[0] for c in ile.CONDITIONS)
_PIECE_NAMES = ile.condition_pieces.outputs
_TIMING = ("step_period", "step_frequency", "speed")
_SI_NAMES = ("speed_m_s", "step_length_m", "step_frequency_hz")
_SI_QUANTITY = {"speed_m_s": "speed", "step_length_m": "step_length",
                 "step_frequency_hz": "step_frequency"}  # fmt: skip
_TARGETS = ("speed", "q_fixed", "step_length", "step_frequency")
_METRIC_BOUNDS = ("step_length", "step_frequency")

# Tolerances of the verification of a returned design (closed forms re-evaluated in numpy).
_FEAS_TOL = 1e-8  # constraint rows, relative to max(1, |bound|)
_ACTIVE_TOL = 1e-6  # a row within this (relative) of a bound is reported active
_MULTIPLIER_TOL = 1e-7  # a multiplier above this (relative) pulls towards the bound
_SCAN_POINTS = 8192
_TARGET_BAND = 0.05  # scan points within 5 % of every target count as seeds for it

_IPOPT_OPTIONS = {
    "ipopt.print_level": 0,
    "print_time": False,
    "ipopt.sb": "yes",
    "ipopt.tol": 1e-10,
    "ipopt.constr_viol_tol": 1e-11,
    "ipopt.acceptable_tol": 1e-7,
    "ipopt.acceptable_constr_viol_tol": 1e-10,
    "ipopt.max_iter": 100,
    "ipopt.mu_strategy": "adaptive",
    # Trial points outside the walking region evaluate to NaN by design; IPOPT cuts the
    # step back, and CasADi must not print a warning for each of them.
    "show_eval_warnings": False,
}
_SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
_INFEASIBLE = ("Infeasible_Problem_Detected", "Restoration_Failed", "Empty_Region")


# --- closed-form quantities (numpy or CasADi) ---------------------------------------------


def _quantities(beta: Any, theta_II: Any, phi0: Any, timing: bool = True) -> dict[str, Any]:
    """Every quantity the NLP uses, from the generated code (numpy arrays or CasADi SX)."""
    q_fixed, eigenvalue, *margins = ile.fixed_point_conditions(beta, theta_II, phi0)
    step_length = ile.step_length(beta, phi0)
    out: dict[str, Any] = {
        "q_fixed": q_fixed,
        "eigenvalue": eigenvalue,
        "step_length": step_length,
        # E_c at the fixed point per unit distance, in units of m g: E_c / (m g L).
        "cost_of_transport": ile.energy_complement(beta, theta_II, phi0, q_fixed, 1.0, 1.0, 1.0)
        / step_length,
    }
    out.update(zip(_MARGIN_NAMES, margins))
    out.update(zip(_PIECE_NAMES, ile.condition_pieces(beta, theta_II, phi0)))
    if timing:
        tau_I_II, tau_III_IV = ile.phase_durations(beta, theta_II, phi0, q_fixed)
        period = tau_I_II + tau_III_IV
        out["step_period"] = period
        out["step_frequency"] = 1.0 / period
        out["speed"] = step_length / period
    return out


def _numpy_quantities(x: np.ndarray, timing: bool = True) -> dict[str, np.ndarray]:
    """:func:`_quantities` on an ``(n, 3)`` array of designs; NaN where undefined."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    with np.errstate(all="ignore"):
        return {
            k: np.broadcast_to(v, x.shape[:1]).astype(float)
            for k, v in _quantities(x[:, 0], x[:, 1], x[:, 2], timing).items()
        }


# --- regions -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Region:
    """A part of the parameter space where the apex margin (14) is one smooth piece.

    Attributes
    ----------
    name : str
    apex_piece : str or None
        The quantity that equals the exact apex margin here (None: q^f > 0 suffices).
    theta_II : (lower, upper)
        Extra bounds on theta_II.
    theta_I_sign : int
        +1: theta_I <= 0 is imposed (beta - cos phi0 >= 0); -1: theta_I >= 0; 0: implied.
    """

    name: str
    apex_piece: str | None
    theta_II: tuple[float, float]
    theta_I_sign: int


_REGIONS = (
    _Region("theta_II <= 0 (apex crossed in phase III-IV)", "apex_phase_III_IV",
            (-math.inf, 0.0), 0),
    _Region("theta_I <= 0 <= theta_II (apex crossed in phase I-II)", "apex_phase_I_II",
            (0.0, math.inf), +1),
    _Region("theta_I >= 0 (apex never crossed)", None, (-math.inf, math.inf), -1),
)  # fmt: skip


def _region_of(x: np.ndarray, qs: Mapping[str, np.ndarray]) -> np.ndarray:
    """Index into _REGIONS of each design (theta_II <= 0 first, then the sign of theta_I)."""
    theta_I_negative = qs["theta_I_negative"]  # beta - cos phi0: > 0 when theta_I < 0
    return np.where(x[:, 1] <= 0, 0, np.where(theta_I_negative >= 0, 1, 2))


# --- the problem ---------------------------------------------------------------------------


@dataclass(frozen=True)
class _Constraint:
    """``lower <= quantity <= upper``; an ``open`` lower bound is excluded from the set.

    Open constraints (strict conditions) are imposed as ``quantity >= lower + distance``
    with the distance of their kind scaled by the continuation; they are what makes an
    optimum "not attained".
    """

    name: str  # reported to the user (active / conflicting constraints)
    quantity: str  # key of _quantities
    lower: float
    upper: float
    user: bool  # a user constraint (relaxed in the conflict analysis)
    relax_key: str = ""  # user constraints with the same key are relaxed together
    open: bool = False


@dataclass
class _Problem:
    weights: dict[str, float]
    lbx: np.ndarray  # closed bounds (user) or the table limits (open, see table_open)
    ubx: np.ndarray
    table_open: set[tuple[int, int]]  # (variable, side) that are open table limits
    bound_names: dict[tuple[int, int], str]  # (variable, 0 lower / 1 upper) -> user name
    constraints: list[_Constraint]
    fixed: dict[str, float]
    conditions: str
    regions: tuple[int, ...]
    request: dict[str, Any]  # the arguments it was built from (see without())

    @property
    def timing(self) -> bool:
        return bool(self.weights.get("speed")) or any(
            c.quantity in _TIMING for c in self.constraints
        )

    def rows(self) -> tuple[str, ...]:
        """The NLP's constraint rows: one per constrained quantity, in a stable order."""
        names: list[str] = []
        for region in self.regions:
            for c in self.region_constraints(region):
                if c.quantity not in names:
                    names.append(c.quantity)
        return tuple(names)

    def structure(self) -> tuple:
        """Cache key of the compiled solver: objective terms, rows and timing."""
        terms = tuple(sorted(k for k, w in self.weights.items() if w != 0))
        return terms, self.rows(), self.timing

    def region_constraints(self, region: int) -> list[_Constraint]:
        """Every constraint that holds in a region, the apex as the region's piece."""
        spec = _REGIONS[region]
        out = list(self.constraints)
        if spec.apex_piece is not None:
            out.append(_Constraint("apex", spec.apex_piece, 0.0, math.inf, False, open=True))
        if spec.theta_I_sign > 0 and self.conditions != "paper":
            out.append(_Constraint("region", "theta_I_negative", 0.0, math.inf, False))
        elif spec.theta_I_sign < 0:
            out.append(_Constraint("region", "theta_I_negative", -math.inf, 0.0, False))
        return out

    def bounds(self, region: int, distance: float) -> tuple[np.ndarray, np.ndarray]:
        """Variable bounds in a region, open table limits kept ``distance`` away."""
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        for i, side in self.table_open:
            if side == 0:
                lbx[i] += TABLE_DISTANCE * distance
            else:
                ubx[i] -= TABLE_DISTANCE * distance
        lo, hi = _REGIONS[region].theta_II
        lbx[1], ubx[1] = max(lbx[1], lo), min(ubx[1], hi)
        return lbx, ubx

    def without(self, relax_key: str) -> _Problem:
        """The same request with one user constraint (group) removed, built anew."""
        request = dict(self.request)
        request["bounds"] = dict(request["bounds"])
        request["fixed"] = dict(request["fixed"])
        request["targets"] = dict(request["targets"])
        if relax_key.startswith("fix_"):
            request["fixed"].pop(relax_key[4:], None)
        elif relax_key == "max_eigenvalue":
            request["max_eigenvalue"] = None
        elif relax_key == "min_contact_margin":
            request["min_contact_margin"] = 0.0  # the physical N >= 0 stays
        elif relax_key.startswith("target_"):
            quantity = relax_key[len("target_") :]
            for name in list(request["targets"]):
                if _SI_QUANTITY.get(name, name) == quantity:
                    del request["targets"][name]
        else:
            side = 0 if relax_key.endswith("_min") or relax_key.startswith("min_") else 1
            quantity = relax_key[:-4] if relax_key[-4:] in ("_min", "_max") else relax_key[4:]
            for name, pair in list(request["bounds"].items()):
                if _SI_QUANTITY.get(name, name) == quantity:
                    lo, hi = _pair(name, pair)
                    request["bounds"][name] = (None, hi) if side == 0 else (lo, None)
        return _build_problem(**request)

    def user_constraints(self) -> list[str]:
        """Relax keys of every user constraint, in a stable order."""
        keys: list[str] = []
        for name in self.bound_names.values():
            if name not in keys:
                keys.append(name)
        for c in self.constraints:
            if c.user and c.relax_key not in keys:
                keys.append(c.relax_key)
        return keys


def _contact_constraints(margin: float) -> list[_Constraint]:
    """N >= margin at instants I, II, IV: exactly the stance contact over the step."""
    user = margin > CLOSED_MARGIN
    name = "min_contact_margin" if user else "stance_contact"
    return [
        _Constraint(name, piece, max(margin, CLOSED_MARGIN), math.inf, user, name if user else "")
        for piece in ("normal_force_I", "normal_force_II", "normal_force_IV")
    ]


def _normalise_objective(objective: Any, has_targets: bool) -> dict[str, float]:
    if objective is None:
        if not has_targets:
            raise VswInputError(
                "design needs an objective (speed, eigenvalue, cost_of_transport) or a target"
            )
        return {"eigenvalue": 1.0}  # a target alone: the most stable gait that meets it
    if isinstance(objective, str):
        key = objective.strip().lower().replace("-", "_").replace(" ", "_")
        if key not in _OBJECTIVE_ALIASES:
            raise VswInputError(
                f"objective = {objective!r} is not one of speed, eigenvalue, cost_of_transport"
            )
        return dict(_OBJECTIVE_ALIASES[key])
    if isinstance(objective, Mapping):
        weights: dict[str, float] = {}
        for name, weight in objective.items():
            key = str(name).replace("-", "_")
            if key == "cot":
                key = "cost_of_transport"
            if key not in OBJECTIVES:
                raise VswInputError(f"objective weight {name!r} is not one of {OBJECTIVES}")
            w = finite(f"objective weight {name}", weight)
            if w < 0:
                raise VswInputError(f"objective weight {name} = {weight!r} must be >= 0")
            weights[key] = w
        if not any(weights.values()):
            raise VswInputError("objective weights are all zero")
        return weights
    raise VswInputError(f"objective = {objective!r} must be a name or a mapping of weights")


def finite(name: str, value: Any) -> float:
    """``value`` as a finite float, or a one-line refusal naming it."""
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise VswInputError(f"{name} = {value!r} is not a real number") from None
    if not math.isfinite(v):
        raise VswInputError(f"{name} = {value!r} must be finite")
    return v


def _si_factors(scale: RobotScale | None) -> dict[str, tuple[str, float]]:
    """SI names -> (dimensionless quantity, factor: dimensionless = SI / factor)."""
    if scale is None:
        return {}
    return {
        "speed_m_s": ("speed", math.sqrt(scale.gravity * scale.leg_length)),
        "step_length_m": ("step_length", scale.leg_length),
        "step_frequency_hz": ("step_frequency", 1.0 / scale.time_unit_s),
    }


def _to_dimensionless(name: str, value: float, scale: RobotScale | None) -> tuple[str, float]:
    if name not in _SI_NAMES:
        return name, value
    if scale is None:
        raise VswInputError(f"{name} is in SI units and needs a robot scale (leg length)")
    quantity, factor = _si_factors(scale)[name]
    with np.errstate(all="ignore"):
        v = float(np.float64(value) / np.float64(factor))
    if not math.isfinite(v) or (value != 0 and v == 0):
        raise VswInputError(
            f"{name} = {value:g} is {'0' if v == 0 else 'infinite'} in the model's units "
            f"({quantity} = {name} / {factor:g}): check the value and the robot scale"
        )
    return quantity, v


def _pair(name: str, pair: Any) -> tuple[Any, Any]:
    if not isinstance(pair, Sequence) or isinstance(pair, str) or len(pair) != 2:
        raise VswInputError(f"bound on {name} = {pair!r}: expected (lower, upper)")
    return pair[0], pair[1]


def _variable_bounds(
    bounds: Mapping[str, tuple[float | None, float | None]],
    fixed: Mapping[str, float],
) -> tuple[np.ndarray, np.ndarray, set[tuple[int, int]], dict[tuple[int, int], str], dict]:
    """Bounds of the decision variables: closed user bounds, or the open table limits.

    A user bound at (or beyond) a table limit is that open limit. A user bound closer to
    it than :data:`TABLE_DISTANCE` is refused: the design never comes that close to an
    open limit, so such a bound could not be honoured as the closed bound it is.
    """
    lbx, ubx = np.empty(3), np.empty(3)
    table_open: set[tuple[int, int]] = set()
    bound_names: dict[tuple[int, int], str] = {}
    fixed_v: dict[str, float] = {}
    for i, name in enumerate(VARIABLES):
        lo_t, hi_t = _TABLE[name]
        lo, hi = lo_t, hi_t
        user_lo, user_hi = _pair(name, bounds.get(name, (None, None)))
        for side, value, limit in ((0, user_lo, lo_t), (1, user_hi, hi_t)):
            if value is None:
                continue
            value = finite(f"{name} {('lower', 'upper')[side]} bound", value)
            beyond = value <= limit if side == 0 else value >= limit
            if beyond:
                continue
            if (value >= hi_t) if side == 0 else (value <= lo_t):
                raise VswInputError(
                    f"{name} {('lower', 'upper')[side]} bound {value:.6g} lies beyond the "
                    f"other table limit of {name} ({(hi_t, lo_t)[side]:.6g})"
                )
            if abs(value - limit) < TABLE_DISTANCE and name not in fixed:
                raise VswInputError(
                    f"{name} {('lower', 'upper')[side]} bound {value:.6g} is closer than "
                    f"{TABLE_DISTANCE:g} to the open limit {limit:.6g} of {name}: use "
                    f"{limit + (TABLE_DISTANCE if side == 0 else -TABLE_DISTANCE):.6g} or "
                    "leave it out (the open limit is the default)"
                )
            if side == 0:
                lo = value
            else:
                hi = value
            bound_names[(i, side)] = f"{name}_{('min', 'max')[side]}"
        if lo > hi:
            raise VswInputError(f"{name} bounds are empty: lower {lo:.6g} > upper {hi:.6g}")
        if name in fixed:
            value = float(check_parameter(name, finite(name, fixed[name])))
            if not lo - 1e-12 <= value <= hi + 1e-12:
                raise VswInputError(f"fixed {name} = {value:.6g} is outside its bounds "
                                    f"[{lo:.6g}, {hi:.6g}]")  # fmt: skip
            lo = hi = value
            fixed_v[name] = value
            bound_names[(i, 0)] = bound_names[(i, 1)] = f"fix_{name}"
        else:
            table_open |= {(i, side) for side in (0, 1) if (i, side) not in bound_names}
            room = hi - lo - TABLE_DISTANCE * sum((i, side) in table_open for side in (0, 1))
            if room < 0:
                raise VswInputError(
                    f"{name} bounds [{lo:.6g}, {hi:.6g}] leave no room inside the open limits "
                    f"of the parameter table (kept {TABLE_DISTANCE:g} away)"
                )
        lbx[i], ubx[i] = lo, hi
    return lbx, ubx, table_open, bound_names, fixed_v


def _build_problem(
    weights: dict[str, float],
    targets: Mapping[str, float] | None,
    bounds: Mapping[str, tuple[float | None, float | None]] | None,
    fixed: Mapping[str, float] | None,
    min_contact_margin: float,
    max_eigenvalue: float | None,
    scale: RobotScale | None,
    conditions: str = "exact",
) -> _Problem:
    if conditions not in CONDITION_SETS:
        raise VswInputError(f"conditions = {conditions!r} is not one of {CONDITION_SETS}")
    bounds = dict(bounds or {})
    fixed = dict(fixed or {})
    for name in bounds:
        if name not in VARIABLES and name not in _METRIC_BOUNDS and name not in _SI_NAMES:
            raise VswInputError(
                f"bound on {name!r}: bounds exist for {VARIABLES + _METRIC_BOUNDS + _SI_NAMES}"
            )
    for name in fixed:
        if name not in VARIABLES:
            raise VswInputError(f"fix {name!r}: only {', '.join(VARIABLES)} can be fixed")
    lbx, ubx, table_open, bound_names, fixed_v = _variable_bounds(bounds, fixed)

    constraints: list[_Constraint] = [
        _Constraint("q_positive", "q_fixed", 0.0, math.inf, False, open=True),
        _Constraint("extension_before_heelstrike", "extension_before_heelstrike", 0.0,
                    math.inf, False, open=True),
        _Constraint("extension_reached", "extension_reached", 0.0, math.inf, False, open=True),
    ]  # fmt: skip
    if conditions == "paper":
        for name in ("theta_I_negative", "extension_before_symmetric_contact"):
            constraints.append(_Constraint(name, name, 0.0, math.inf, False, open=True))
    margin = finite("min_contact_margin", min_contact_margin)
    if margin < 0:
        raise VswInputError(
            f"min_contact_margin = {min_contact_margin!r} must be >= 0 (m g): the stance foot "
            "must stay on the ground, N >= 0, always"
        )
    constraints += _contact_constraints(margin)
    if max_eigenvalue is not None:
        v = finite("max_eigenvalue", max_eigenvalue)
        constraints.append(
            _Constraint("max_eigenvalue", "eigenvalue", -math.inf, v, True, "max_eigenvalue")
        )
    metric: dict[str, list[float]] = {}
    for name, pair in bounds.items():
        if name in VARIABLES:
            continue
        for side, value in enumerate(_pair(name, pair)):
            if value is None:
                continue
            quantity, v = _to_dimensionless(name, finite(f"{name} bound", value), scale)
            metric.setdefault(quantity, [-math.inf, math.inf])
            if side == 0:
                metric[quantity][0] = max(metric[quantity][0], v)
            else:
                metric[quantity][1] = min(metric[quantity][1], v)
    for quantity, (lo, hi) in metric.items():
        if lo > hi:
            raise VswInputError(f"{quantity} bounds are empty: lower {lo:.6g} > upper {hi:.6g}")
        if lo > -math.inf:
            key = f"min_{quantity}"
            constraints.append(_Constraint(key, quantity, lo, math.inf, True, key))
        if hi < math.inf:
            key = f"max_{quantity}"
            constraints.append(_Constraint(key, quantity, -math.inf, hi, True, key))
    seen: dict[str, float] = {}
    for name, value in (targets or {}).items():
        if name not in _TARGETS and name not in _SI_NAMES:
            raise VswInputError(f"target {name!r} is not one of {_TARGETS + _SI_NAMES}")
        quantity, v = _to_dimensionless(name, finite(f"target {name}", value), scale)
        if v <= 0:
            raise VswInputError(f"target {name} = {value!r} must be > 0")
        if quantity in seen and not math.isclose(seen[quantity], v, rel_tol=1e-12):
            raise VswInputError(f"two different targets for {quantity}")
        seen[quantity] = v
        lo, hi = metric.get(quantity, (-math.inf, math.inf))
        if not lo <= v <= hi:
            raise VswInputError(
                f"target {name} = {value!r} lies outside its own bounds [{lo:.6g}, {hi:.6g}]"
            )
        if quantity == "q_fixed" and v <= STRICT_MARGIN:
            raise VswInputError(
                f"target q_fixed = {value!r} must exceed {STRICT_MARGIN:g}: q^f > 0 (eq. 12) "
                "is kept that far from its open limit"
            )
        key = f"target_{quantity}"
        constraints.append(_Constraint(key, quantity, v, v, True, key))
    # The paper's (15) is theta_I < 0, which rules out the region where theta_I >= 0.
    regions = (0, 1) if conditions == "paper" else (0, 1, 2)
    request = {
        "weights": weights, "targets": dict(targets or {}), "bounds": bounds, "fixed": fixed,
        "min_contact_margin": margin, "max_eigenvalue": max_eigenvalue, "scale": scale,
        "conditions": conditions,
    }  # fmt: skip
    return _Problem(weights, lbx, ubx, table_open, bound_names, constraints, fixed_v,
                    conditions, regions, request)  # fmt: skip


# --- compiled solvers, cached per problem structure ---------------------------------------

_SOLVERS: dict[tuple, Any] = {}

_WARM_OPTIONS = {
    # Continuation towards an open limit restarts from the previous solution, which lies
    # on the (moved) bounds: keep it there instead of pushing it 1 % into the interior.
    "ipopt.warm_start_init_point": "yes",
    "ipopt.bound_push": 1e-12,
    "ipopt.bound_frac": 1e-12,
    "ipopt.warm_start_bound_push": 1e-12,
    "ipopt.warm_start_bound_frac": 1e-12,
    "ipopt.warm_start_mult_bound_push": 1e-12,
    "ipopt.mu_init": 1e-9,
    "ipopt.max_iter": 80,
}


_PROBE_OPTIONS = {
    # Conflict analysis asks of each relaxed request only whether it is feasible; most stay
    # infeasible, which IPOPT detects sooner when told to expect it.
    "ipopt.expect_infeasible_problem": "yes",
    "ipopt.max_iter": 60,
}
_VARIANTS = {"cold": {}, "warm": _WARM_OPTIONS, "probe": _PROBE_OPTIONS}


def _solver(problem: _Problem, variant: str = "cold") -> Any:
    """The ``nlpsol`` for the problem's structure, built once and cached.

    Parameters of the NLP (p): the objective weights and one scale per row, so bounds,
    targets, weights and the region (rows switched off with infinite bounds) change
    without rebuilding. ``variant``: 'cold' starts, 'warm' starts (continuation) or
    'probe' (feasibility questions of the conflict analysis).
    """
    key = (problem.structure(), variant)
    if key in _SOLVERS:
        return _SOLVERS[key]
    import casadi as ca

    terms, rows, timing = key[0]
    x = ca.SX.sym("x", 3)
    qs = _quantities(x[0], x[1], x[2], timing)
    w = ca.SX.sym("w", len(terms))
    row_scale = ca.SX.sym("s", len(rows))
    f = sum((_SIGN[t] * w[i] * qs[t] for i, t in enumerate(terms)), ca.SX(0))
    g = ca.vertcat(*[qs[r] * row_scale[i] for i, r in enumerate(rows)])
    p = ca.vertcat(w, row_scale)
    options = {**_IPOPT_OPTIONS, **_VARIANTS[variant]}
    solver = ca.nlpsol("vsw_design", "ipopt", {"x": x, "f": f, "g": g, "p": p}, options)
    _SOLVERS[key] = solver
    return solver


# --- constraint values, violations, objective (numpy) --------------------------------------


def _shifted(c: _Constraint, distance: float) -> tuple[float, float]:
    """Bounds of a constraint as imposed: open lower bounds kept ``distance`` inside."""
    lower = c.lower + STRICT_MARGIN * distance if c.open else c.lower
    return lower, c.upper


def _size(c: _Constraint, floor: float = 1.0) -> float:
    """The scale of a constraint's bounds: violations and rows are relative to it."""
    finite = [abs(b) for b in (c.lower, c.upper) if math.isfinite(b)]
    return max([floor, *finite])


def _objective_values(problem: _Problem, qs: Mapping[str, np.ndarray]) -> np.ndarray:
    total = np.zeros_like(qs["q_fixed"])
    for term, w in problem.weights.items():
        if w:
            total = total + _SIGN[term] * w * qs[term]
    return total


def _user_violation(
    problem: _Problem, qs: Mapping[str, np.ndarray], floor: float = 1.0
) -> np.ndarray:
    """Sum of the user constraints' violations, each relative to ``max(floor, |bound|)``
    (inf where a value is NaN)."""
    total = np.zeros_like(qs["q_fixed"])
    with np.errstate(invalid="ignore"):
        for c in problem.constraints:
            if not c.user:
                continue
            v = qs[c.quantity]
            excess = np.maximum(c.lower - v, 0.0) + np.maximum(v - c.upper, 0.0)
            total = total + np.where(np.isfinite(v), excess / _size(c, floor), np.inf)
    return total


def _physical_violation(problem: _Problem, qs: Mapping[str, np.ndarray]) -> np.ndarray:
    """Violation of the exact conditions: 0 where every physical (and with
    ``conditions='paper'``, every paper) condition holds in its exact strict form."""
    total = np.zeros_like(qs["q_fixed"])
    names = [c[0] for c in ile.CONDITIONS if c[4] and c[0] != "phi0_below_right_angle"]
    if problem.conditions == "paper":
        names += ["theta_I_negative", "extension_before_symmetric_contact"]
    with np.errstate(invalid="ignore"):
        for name in names:
            v = qs[name]
            holds = v > 0 if _CONDITION[name][2] else v >= 0
            total = total + np.where(holds, 0.0, np.where(np.isfinite(v), np.abs(v) + 1e-12,
                                                          np.inf))  # fmt: skip
    return total


# --- starts --------------------------------------------------------------------------------


def _halton(n: int, dims: int = 3) -> np.ndarray:
    """The first ``n`` points of the Halton sequence (bases 2, 3, 5), skipping 0."""
    out = np.empty((n, dims))
    index = np.arange(1, n + 1)
    for d, base in enumerate((2, 3, 5)[:dims]):
        value = np.zeros(n)
        f = 1.0 / base
        i = index.copy()
        while np.any(i):
            value += f * (i % base)
            i //= base
            f /= base
        out[:, d] = value
    return out


@dataclass
class _Scan:
    x: np.ndarray
    qs: dict[str, np.ndarray]
    region: np.ndarray
    physical: np.ndarray  # violation of the exact conditions
    user: np.ndarray  # violation of the user constraints (relative to max(1, |bound|))
    band: np.ndarray  # the same relative to |bound|: the distance from a target in %
    objective: np.ndarray
    defined: np.ndarray  # the objective and every NLP row are numbers: IPOPT can start here

    def feasible(self, tol: float = _FEAS_TOL) -> np.ndarray:
        return (self.physical == 0) & (self.user <= tol) & self.defined


def _scan(problem: _Problem, n: int = _SCAN_POINTS) -> _Scan:
    """The closed forms at ``n`` Halton points of the box (open limits kept away)."""
    lbx, ubx = problem.bounds(2, 1.0)  # region 2 has no theta_II restriction
    x = lbx + (ubx - lbx) * _halton(n)
    qs = _numpy_quantities(x, timing=problem.timing)
    objective = _objective_values(problem, qs)
    defined = np.isfinite(objective)
    for row in problem.rows():
        defined &= np.isfinite(qs[row])
    return _Scan(x, qs, _region_of(x, qs), _physical_violation(problem, qs),
                 _user_violation(problem, qs), _user_violation(problem, qs, 1e-300),
                 objective, defined)  # fmt: skip


def _seeds(problem: _Problem, scan: _Scan, per_region: int) -> list[tuple[int, np.ndarray]]:
    """(region, start) pairs, most promising first.

    In each region: the points that satisfy every condition and come within
    :data:`_TARGET_BAND` of the user constraints, best objective first, spread apart; or,
    when there is none, the least-violating point. Regions ordered by their best seed.
    """
    span = np.maximum(problem.ubx - problem.lbx, 1e-12)
    span = np.where(np.isfinite(span), span, 1.0)
    ranked: list[tuple[tuple[float, float], int, np.ndarray]] = []
    objective = np.nan_to_num(scan.objective, nan=np.inf)
    for region in problem.regions:
        inside = scan.region == region
        if not inside.any():
            continue
        inside &= scan.defined
        near = inside & (scan.physical == 0) & (scan.band <= _TARGET_BAND)
        chosen: list[np.ndarray] = []
        keys: list[tuple[float, float]] = []
        for idx in np.flatnonzero(near)[np.argsort(objective[near], kind="stable")]:
            point = scan.x[idx]
            if all(np.max(np.abs(point - c) / span) > 0.15 for c in chosen):
                chosen.append(point)
                keys.append((0.0, float(objective[idx])))
            if len(chosen) == per_region:
                break
        merit = scan.physical + scan.user
        merit = np.where(inside & np.isfinite(merit), merit, np.inf)
        best = int(np.argmin(merit))
        if not chosen and np.isfinite(merit[best]):
            chosen.append(scan.x[best])
            keys.append((1.0 + float(merit[best]), float(objective[best])))
        ranked += [(k, region, point) for k, point in zip(keys, chosen)]
    ranked.sort(key=lambda item: item[0])
    return [(region, point) for _, region, point in ranked]


# --- solve ---------------------------------------------------------------------------------


@dataclass
class _Solve:
    """One IPOPT solve in one region; ``check`` fills the verification fields."""

    x: np.ndarray
    region: int
    distance: float
    objective: float  # IPOPT's; replaced by the numpy value when checked
    ipopt_status: str
    iterations: int
    lam_x: np.ndarray
    lam_g: np.ndarray
    checked: bool = False
    verified: bool = False  # every constraint confirmed by the closed forms in numpy
    violation: float = math.inf  # user constraints (relative) + exact conditions
    open_active: tuple[str, ...] = ()  # open limits the optimum presses against

    @property
    def converged(self) -> bool:
        return self.ipopt_status in _SUCCESS

    @property
    def success(self) -> bool:
        return self.converged and self.verified


def _row_bounds(
    problem: _Problem, region: int, distance: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lbg, ubg, scales) of the NLP rows in a region: every constraint on a quantity
    intersected into its row, rows a region does not use left free."""
    _, rows, _ = problem.structure()
    lower = dict.fromkeys(rows, -math.inf)
    upper = dict.fromkeys(rows, math.inf)
    size = dict.fromkeys(rows, 1.0)
    for c in problem.region_constraints(region):
        lo, hi = _shifted(c, distance)
        lower[c.quantity] = max(lower[c.quantity], lo)
        upper[c.quantity] = min(upper[c.quantity], hi)
        size[c.quantity] = max(size[c.quantity], _size(c))
    scales = np.array([1.0 / size[r] for r in rows])
    lbg = np.array([lower[r] for r in rows]) * scales
    ubg = np.array([upper[r] for r in rows]) * scales
    return lbg, ubg, scales


def _solve_from(
    problem: _Problem,
    region: int,
    x0: np.ndarray,
    distance: float = 1.0,
    warm: _Solve | None = None,
    probe: bool = False,
) -> _Solve:
    terms, _rows, _ = problem.structure()
    lbx, ubx = problem.bounds(region, distance)
    lbg, ubg, scales = _row_bounds(problem, region, distance)
    if np.any(lbx > ubx) or np.any(lbg > ubg):
        empty = np.zeros(0)
        return _Solve(np.clip(x0, problem.lbx, problem.ubx), region, distance, math.inf,
                      "Empty_Region", 0, empty, empty, checked=True)  # fmt: skip
    solver = _solver(problem, "warm" if warm is not None else "probe" if probe else "cold")
    p = np.concatenate([[problem.weights[t] for t in terms], scales])
    start: dict[str, Any] = {"x0": np.clip(x0, lbx, ubx)}
    if warm is not None and len(warm.lam_x):
        start.update(lam_x0=warm.lam_x, lam_g0=warm.lam_g)
    # CasADi writes some diagnostics (over-constrained NLP, multipliers not computed) to
    # Python's stderr; the result object carries what matters, so they are swallowed.
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        sol = solver(p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, **start)
    stop.check()  # IPOPT ends an interrupted solve with a status, not an exception
    stats = solver.stats()
    x = np.clip(np.array(sol["x"], dtype=float).reshape(-1), lbx, ubx)
    return _Solve(
        x, region, distance, float(sol["f"]), str(stats.get("return_status", "unknown")),
        int(stats.get("iter_count", -1)), np.array(sol["lam_x"], dtype=float).reshape(-1),
        np.array(sol["lam_g"], dtype=float).reshape(-1),
    )  # fmt: skip


def _check(problem: _Problem, s: _Solve) -> _Solve:
    """Verify a solve with the closed forms in numpy (IPOPT's word is not enough): every
    user constraint to _FEAS_TOL, every physical condition in its exact strict form."""
    if s.checked:
        return s
    qs = _numpy_quantities(s.x[None, :], timing=True)
    s.objective = float(_objective_values(problem, qs)[0])
    user = float(_user_violation(problem, qs)[0])
    physical = float(_physical_violation(problem, qs)[0])
    s.violation = user + physical
    s.verified = (
        user <= _FEAS_TOL
        and physical == 0
        and math.isfinite(s.objective)
        and math.isfinite(float(qs["speed"][0]))
    )
    if s.verified:
        _, rows, _ = problem.structure()
        _, _, scales = _row_bounds(problem, s.region, s.distance)
        lam_g = dict(zip(rows, s.lam_g * scales))  # multipliers of the unscaled rows
        s.open_active = _open_active(problem, s, qs, lam_g)
    s.checked = True
    return s


def _open_active(
    problem: _Problem, s: _Solve, qs: Mapping[str, np.ndarray], lam_g: Mapping[str, float]
) -> tuple[str, ...]:
    """Open limits at their kept distance whose multiplier pulls the optimum onto them."""
    pull = _MULTIPLIER_TOL * max(1.0, abs(s.objective))
    names: list[str] = []
    for i, side in sorted(problem.table_open):
        # The kept bound itself, not the region's (theta_II = 0 bounds two regions).
        bound = _kept_table_bound(i, side, s.distance)
        near = abs(s.x[i] - bound) <= _ACTIVE_TOL * max(1.0, abs(bound))
        if near and abs(s.lam_x[i]) > pull:
            names.append(_limit_name(i, side))
    for c in problem.region_constraints(s.region):
        if not c.open:
            continue
        lower, _ = _shifted(c, s.distance)
        value = float(qs[c.quantity][0])
        near = abs(value - lower) <= _ACTIVE_TOL * max(1.0, abs(lower)) + 1e-12
        if near and abs(lam_g.get(c.quantity, 0.0)) > pull and c.name not in names:
            names.append(c.name)
    return tuple(names)


def _kept_table_bound(i: int, side: int, distance: float) -> float:
    limit = _TABLE[VARIABLES[i]][side]
    return limit + (1 if side == 0 else -1) * TABLE_DISTANCE * distance


def _limit_text(limit: float) -> str:
    """A table limit as people write it: 1, 0, pi/2, -pi/2."""
    if abs(abs(limit) - math.pi / 2) < 1e-12:
        return "-pi/2" if limit < 0 else "pi/2"
    return f"{limit:g}"


def _limit_name(i: int, side: int) -> str:
    name = VARIABLES[i]
    if name == "phi0" and side == 1:
        return "phi0_below_right_angle"
    return f"{name} {'>' if side == 0 else '<'} {_limit_text(_TABLE[name][side])}"


def _better(a: _Solve, b: _Solve | None) -> bool:
    return b is None or a.objective < b.objective - 1e-12 * max(1.0, abs(b.objective))


def _multistart(
    problem: _Problem, per_region: int, scan: _Scan | None = None, probe: bool = False
) -> tuple[_Solve | None, list[_Solve], _Scan]:
    """Best verified converged solve (or None), every solve, and the scan.

    Only a converged solve that beats the best so far is verified (a numpy evaluation
    costs about as much as a short solve).
    """
    scan = _scan(problem) if scan is None else scan
    solves: list[_Solve] = []
    best: _Solve | None = None

    def consider(s: _Solve) -> None:
        nonlocal best
        solves.append(s)
        # IPOPT's objective first (cheap); the checked, numpy one decides.
        if s.converged and _better(s, best) and _check(problem, s).verified:
            if _better(s, best):
                best = s

    for region, x0 in _seeds(problem, scan, per_region):
        consider(_solve_from(problem, region, x0, probe=probe))
        if probe and best is not None:
            break
    # An optimum on the boundary between two regions may continue into the neighbour.
    if best is not None:
        tried = {s.region for s in solves}
        for other in _neighbours(problem, best):
            if other not in tried:
                consider(_solve_from(problem, other, best.x))
    return best, solves, scan


def _neighbours(problem: _Problem, s: _Solve) -> list[int]:
    """Regions that share the boundary the solution lies on."""
    out = []
    if abs(s.x[1]) <= 1e-9 and s.region in (0, 1):
        out.append(1 - s.region)
    qs = _numpy_quantities(s.x[None, :], timing=False)
    if abs(float(qs["theta_I_negative"][0])) <= 1e-9 and s.region in (1, 2):
        out.append(3 - s.region)
    return [r for r in out if r in problem.regions]


# --- the limit of a not-attained optimum ---------------------------------------------------


@dataclass(frozen=True)
class Limit:
    """The supremum or infimum of a request whose optimum is not attained.

    Attributes
    ----------
    objective : float or None
        Extrapolated limiting value of the objective (None when the path does not settle;
        ``inf``/``-inf`` when it runs away).
    uncertainty : float or None
        Size of the extrapolation step: the limit is within about this of ``objective``.
    approached_as : tuple of str
        The open limits pressed against: strict conditions by name, parameter limits as
        ``beta < 1``.
    path : tuple of dict
        The design at each distance scale of :data:`CONTINUATION`: ``distance_scale``,
        ``objective``, ``beta``, ``theta_II``, ``phi0``, ``step_length``.
    """

    objective: float | None
    uncertainty: float | None
    approached_as: tuple[str, ...]
    path: tuple[dict[str, float], ...]

    def to_dict(self) -> dict[str, Any]:
        return {
            "objective": _json_float(self.objective),
            "uncertainty": _json_float(self.uncertainty),
            "approached_as": list(self.approached_as),
            "path": [dict(p) for p in self.path],
        }


def _json_float(v: float | None) -> Any:
    if v is None:
        return None
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return v


def _continue_to_limit(problem: _Problem, best: _Solve) -> Limit:
    """Re-solve ever closer to the open limits; extrapolate the objective's limit."""
    path = [best]
    for scale in CONTINUATION[1:]:
        s = _check(problem, _solve_from(problem, best.region, path[-1].x, scale, path[-1]))
        # Close to a degenerate limit IPOPT may stop on its iteration limit: a verified
        # point that improves on the previous one still traces the path (marked).
        if not (s.verified and s.objective <= path[-1].objective + 1e-12):
            break
        path.append(s)
    # Only converged points estimate the limit (a verified point IPOPT did not finish is
    # a bound on the optimum at its distance, not the optimum).
    converged = list(itertools.takewhile(lambda s: s.converged, path))
    limit, uncertainty = _extrapolate([s.objective for s in converged])
    approached = list(best.open_active)
    for s in path[1:]:
        approached += [n for n in s.open_active if n not in approached]
    records = []
    for s in path:
        qs = _numpy_quantities(s.x[None, :], timing=False)
        records.append(
            {
                "distance_scale": s.distance,
                "objective": s.objective,
                "converged": s.success,
                "beta": float(s.x[0]),
                "theta_II": float(s.x[1]),
                "phi0": float(s.x[2]),
                "step_length": float(qs["step_length"][0]),
            }
        )
    approached += [n for n in _running_to_limits(records) if n not in approached]
    return Limit(limit, uncertainty, tuple(approached), tuple(records))


_STEP = CONTINUATION[1] / CONTINUATION[0]  # distance ratio of successive path points


def _running_to_limits(records: Sequence[Mapping[str, float]]) -> list[str]:
    """Variables (and the step length) that close in on a limit along the path: their gap
    to it shrinks at every step at least like distance**(1/4) and ends below 0.05."""
    if len(records) < 3:
        return []
    out = []
    candidates = [(name, limit) for name in VARIABLES for limit in _TABLE[name]]
    candidates.append(("step_length", 0.0))
    for name, limit in candidates:
        gaps = [abs(r[name] - limit) for r in records]
        shrinking = all(b < _STEP**0.25 * a for a, b in itertools.pairwise(gaps))
        if shrinking and gaps[-1] < 0.05:
            out.append(f"{name} -> {_limit_text(limit)}")
    return out


def _extrapolate(values: Sequence[float]) -> tuple[float | None, float | None]:
    """Limit of the objective along the path (distances shrinking by :data:`_STEP`).

    With the objective behaving like ``f* + c d**p`` the steps shrink by a constant ratio
    ``_STEP**p``, and the tail after the last point is ``step * r / (1 - r)``. Needs three
    values; ``inf`` when three steps grow; None when the steps do not settle.
    """
    if len(values) < 3:
        return None, None
    last = values[-1]
    steps = np.diff(values)
    if abs(steps[-1]) <= 1e-12 * max(1.0, abs(last)):
        return float(last), float(abs(steps[-1]))
    if steps[-2] == 0:
        return None, None
    ratio = steps[-1] / steps[-2]
    if 0 < ratio < 0.9:
        tail = steps[-1] * ratio / (1 - ratio)
        # How sure the tail is: the same tail with the previous ratio (a settled sequence
        # keeps its ratio); with only three values, the whole tail.
        uncertainty = abs(tail)
        if len(steps) >= 3 and steps[-3] != 0 and 0 < steps[-2] / steps[-3] < 0.9:
            before = steps[-2] / steps[-3]
            uncertainty = abs(tail - steps[-1] * before / (1 - before))
        return float(last + tail), float(uncertainty + 4e-16 * max(1.0, abs(last)))
    growing = len(steps) >= 3 and all(
        abs(b) >= 1.5 * abs(a) and a * b > 0 for a, b in itertools.pairwise(steps)
    )
    if growing:
        return (-math.inf if steps[-1] < 0 else math.inf), None
    return None, None


# --- result --------------------------------------------------------------------------------


@dataclass(frozen=True)
class DesignResult:
    """Outcome of :func:`design`.

    Attributes
    ----------
    status : {'optimal', 'not-attained', 'infeasible', 'not-converged'}
        'optimal': IPOPT converged and the closed forms confirm every constraint; a local
        optimum, the best over the regions and starts, inside every open limit.
        'not-attained': the best design presses against an open limit (see ``limit``).
    beta, theta_II, phi0 : float or None
        The design (radians); None unless a design was found.
    analysis : vsw.models.ile.analysis.Analysis or None
        All outputs of ``vsw analyze`` at the design.
    objective : float or None
        The minimised weighted sum (speed enters with a minus sign).
    cost_of_transport, step_frequency : float or None
        E_c / (m g L) (L the step length) and 1 / step period at the design.
    active_constraints : tuple of str
        Constraints at their bound (targets always).
    open_boundary : tuple of str
        Open limits the optimum presses against (strict conditions, open parameter
        limits); the design keeps STRICT_MARGIN (conditions) and TABLE_DISTANCE (parameter
        limits) away from them.
    limit : Limit or None
        For 'not-attained': the limiting objective value and the path towards it.
    simulation_rel_error : float or None
        Largest relative difference of q^f, step period, step length and speed between the
        closed form and the time-domain simulation started at q^f.
    conflicting_constraints : tuple of str
        When infeasible: user constraints whose removal alone restores feasibility.
    message : str
        One line saying what happened.
    ipopt_status : str
        Return status of the IPOPT solve behind the result.
    starts : int
        Number of IPOPT solves.
    conditions : {'exact', 'paper'}
        The set of existence conditions imposed.
    region : str or None
        The region of the design (where the apex is crossed).
    """

    status: str
    beta: float | None = None
    theta_II: float | None = None
    phi0: float | None = None
    analysis: Any = None
    objective: float | None = None
    cost_of_transport: float | None = None
    step_frequency: float | None = None
    active_constraints: tuple[str, ...] = ()
    open_boundary: tuple[str, ...] = ()
    limit: Limit | None = None
    simulation_rel_error: float | None = None
    conflicting_constraints: tuple[str, ...] = ()
    message: str = ""
    ipopt_status: str = ""
    starts: int = 0
    conditions: str = "exact"
    region: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON contract of ``vsw design --json``: the analysis keys plus the design's."""
        from vsw.models.ile.analysis import FIELDS

        out: dict[str, Any] = {"status": self.status}
        if self.analysis is not None:
            out.update(self.analysis.to_dict())
        else:
            out.update({"beta": None, "theta_II": None, "phi0": None})
            out.update({name: None for name in FIELDS})
            out["conditions"] = []
            out["energy_unit"] = "m g r_e"
        out["status"] = self.status
        if self.analysis is not None and self.analysis.scale is not None:
            out["step_frequency_hz"] = 1.0 / float(self.analysis.step_period_s)
        out.update(
            {
                "condition_set": self.conditions,
                "objective": self.objective,
                "cost_of_transport": self.cost_of_transport,
                "step_frequency": self.step_frequency,
                "active_constraints": list(self.active_constraints),
                "open_boundary": list(self.open_boundary),
                "limit": None if self.limit is None else self.limit.to_dict(),
                "region": self.region,
                "simulation_rel_error": self.simulation_rel_error,
                "conflicting_constraints": list(self.conflicting_constraints),
                "message": self.message,
                "ipopt_status": self.ipopt_status,
                "starts": self.starts,
            }
        )
        return out


def _active(problem: _Problem, s: _Solve) -> list[str]:
    """Names of the constraints at their bound at a solution."""
    qs = _numpy_quantities(s.x[None, :])
    active: list[str] = []
    for (i, side), name in sorted(problem.bound_names.items()):
        bound = problem.lbx[i] if side == 0 else problem.ubx[i]  # the user's own
        if name.startswith("fix_"):
            if side == 0:
                active.append(name)
        elif abs(s.x[i] - bound) <= _ACTIVE_TOL * max(1.0, abs(bound)):
            active.append(name)
    for c in problem.region_constraints(s.region):
        if c.name == "region":
            continue
        v = float(qs[c.quantity][0])
        for bound in _shifted(c, s.distance):
            near = abs(v - bound) <= _ACTIVE_TOL * max(1.0, abs(bound)) + 1e-12
            if math.isfinite(bound) and near and c.name not in active:
                active.append(c.name)
    return active


def simulation_check(analysis: Any) -> float:
    """Relative error of the closed forms against the time-domain simulation at q^f.

    The largest relative difference of q^f (after each of two simulated steps), the step
    period, the step length and the speed; ``inf`` when the simulation does not complete
    the two steps.
    """
    from vsw.models.ile.simulate import simulate

    beta, theta_II, phi0 = (float(v) for v in (analysis.beta, analysis.theta_II, analysis.phi0))
    q_fixed = float(analysis.q_fixed)
    sim = simulate(beta, theta_II, phi0, q_fixed, 2, record=False)
    if sim.ended != "completed":
        return math.inf
    errors = [abs(q - q_fixed) / q_fixed for q in sim.q[1:]]
    for closed, simulated in (
        (float(analysis.step_period), sim.step_periods),
        (float(analysis.step_length), sim.step_lengths),
        (float(analysis.speed), sim.step_lengths / sim.step_periods),
    ):
        errors.extend(abs(s - closed) / abs(closed) for s in simulated)
    return float(max(errors))


def _conflicts(problem: _Problem, per_region: int) -> list[str]:
    """User constraints whose removal alone makes the request feasible."""
    conflicting = []
    for key in problem.user_constraints():
        relaxed = problem.without(key)
        # A scanned point that satisfies everything settles it without a solve.
        scan = _scan(relaxed)
        if scan.feasible().any() or _multistart(relaxed, 1, scan, probe=True)[0] is not None:
            conflicting.append(key)
    return conflicting


def _describe_objective(problem: _Problem) -> tuple[str, str]:
    """('supremum' or 'infimum', what) of the request's objective."""
    terms = [t for t, w in problem.weights.items() if w]
    if terms == ["speed"]:
        return "supremum", "speed"
    if len(terms) == 1:
        return "infimum", terms[0].replace("_", " ")
    return "infimum", "weighted objective"


def _not_attained_message(problem: _Problem, limit: Limit, s: _Solve) -> str:
    kind, what = _describe_objective(problem)
    sign = -1.0 if kind == "supremum" else 1.0
    if limit.objective is None:
        value = "not estimated (fewer than three re-solves closer to it converged)"
    elif math.isinf(limit.objective):
        value = "unbounded"
    else:
        value = f"{sign * limit.objective:.8g} (+- {limit.uncertainty:.2g}, extrapolated)"
    last = limit.path[-1]
    return (
        f"not attained: the {kind} of the {what}, {value}, lies on the open boundary "
        f"{', '.join(limit.approached_as)}; the design keeps {TABLE_DISTANCE:g} from open "
        f"parameter limits and {STRICT_MARGIN:g} from strict conditions ({what} "
        f"{sign * s.objective:.8g}; {sign * last['objective']:.8g} at "
        f"{last['distance_scale']:g} of those distances)"
    )


def design(
    objective: str | Mapping[str, float] | None = None,
    targets: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float | None, float | None]] | None = None,
    fixed: Mapping[str, float] | None = None,
    min_contact_margin: float = 0.0,
    max_eigenvalue: float | None = None,
    scale: RobotScale | None = None,
    *,
    conditions: str = "exact",
    n_starts: int = 2,
    verify: bool = True,
    explain_infeasible: bool = True,
) -> DesignResult:
    """Design gait parameters (beta, theta_II, phi0) by constrained optimisation.

    Parameters
    ----------
    objective : str or mapping, optional
        ``'speed'`` (maximise), ``'eigenvalue'`` or ``'cost_of_transport'`` (minimise), or
        weights ``{'speed': w1, 'eigenvalue': w2, 'cost_of_transport': w3}`` of the sum
        ``-w1 speed + w2 eigenvalue + w3 cost_of_transport`` that is minimised. Default:
        minimise the eigenvalue when a target is given.
    targets : mapping, optional
        Equality constraints: ``speed`` (sqrt(g r_e)), ``speed_m_s``, ``q_fixed`` (g/r_e),
        ``step_length`` (r_e), ``step_length_m``, ``step_frequency`` (1/sqrt(r_e/g)),
        ``step_frequency_hz``. SI names need ``scale``.
    bounds : mapping, optional
        ``name: (lower, upper)``, either may be None: ``beta``, ``theta_II``, ``phi0``
        (radians), ``step_length``, ``step_frequency`` and their SI names. Closed bounds;
        the parameter table's limits (0 < beta < 1, |theta_II| < pi/2, 0 < phi0 < pi/2) are
        open and kept :data:`TABLE_DISTANCE` away.
    fixed : mapping, optional
        Fixed values of ``beta``, ``theta_II``, ``phi0`` (radians).
    min_contact_margin : float
        Lower bound on the minimum ground normal force over the step, in m g (>= 0 is
        always imposed: the stance foot must stay on the ground).
    max_eigenvalue : float, optional
        Upper bound on the eigenvalue of the stride map (eq. 19).
    scale : RobotScale, optional
        Robot scale for SI targets/bounds and SI outputs.
    conditions : {'exact', 'paper'}
        The existence conditions imposed: every physical condition in its exact form, or in
        addition the paper's (15) (theta_I < 0: the new foot lands ahead of the hip) and
        (17) (theta_II < phi0 / 2) as printed.
    n_starts : int
        IPOPT starts per region of the parameter space (see the module docstring).
    verify : bool
        Re-check the design by time-domain simulation (``simulation_rel_error``).
    explain_infeasible : bool
        When infeasible, relax each user constraint in turn to name the conflicting ones.

    Returns
    -------
    DesignResult

    Raises
    ------
    VswInputError
        Malformed request (unknown names, empty bounds, SI values without a scale, values
        that overflow in the model's units, ...).
    """
    weights = _normalise_objective(objective, bool(targets))
    if not isinstance(n_starts, int) or isinstance(n_starts, bool) or not 1 <= n_starts <= 50:
        raise VswInputError(f"n_starts = {n_starts!r} must be an integer from 1 to 50")
    problem = _build_problem(
        weights, targets, bounds, fixed, min_contact_margin, max_eigenvalue, scale, conditions
    )
    best, solves, scan = _multistart(problem, n_starts)
    common = {"starts": len(solves), "conditions": conditions}
    if best is None:
        statuses = ", ".join(sorted({s.ipopt_status for s in solves})) or "no start"
        feasible_seen = scan.feasible().any() or any(_check(problem, s).verified for s in solves)
        # Infeasible is said on evidence: no scanned point satisfies the constraints and
        # every start ended at a (local) minimum of the constraint violation. A start that
        # ran out of iterations proves nothing.
        locally_infeasible = all(s.ipopt_status in _INFEASIBLE for s in solves)
        if not feasible_seen and locally_infeasible:
            conflicting = _conflicts(problem, n_starts) if explain_infeasible else []
            if conflicting:
                detail = "removing any one of these restores feasibility: " + ", ".join(conflicting)
            elif explain_infeasible:
                detail = "no single user constraint's removal restores feasibility"
            else:
                detail = "conflict analysis skipped"
            least = min((s.violation for s in solves), default=math.inf)
            starts = (
                f"each of {len(solves)} IPOPT starts ended at a minimum of the constraint "
                f"violation or in an empty region, least {least:.3g}"
                if solves
                else "none of them is a gait IPOPT could start from"
            )
            message = (
                f"infeasible: no design satisfies the constraints (none of {len(scan.x)} "
                f"scanned designs; {starts}); {detail}"
            )
            return DesignResult("infeasible", conflicting_constraints=tuple(conflicting),
                                message=message, ipopt_status=statuses, **common)  # fmt: skip
        beyond = _speed_beyond_reach(
            targets,
            bounds,
            fixed,
            min_contact_margin,
            max_eigenvalue,
            scale,
            conditions,
            n_starts,
        )
        if beyond is not None:
            return DesignResult("infeasible", message=f"infeasible: {beyond}",
                                ipopt_status=statuses, **common)  # fmt: skip
        found = "the scan found feasible designs" if feasible_seen else "no feasible design found"
        message = (
            f"not converged: IPOPT reached no verified optimum from {len(solves)} starts "
            f"({statuses}); {found}"
        )
        return DesignResult("not-converged", message=message, ipopt_status=statuses, **common)

    from vsw.models.ile.analysis import analyze

    limit = _continue_to_limit(problem, best) if best.open_active else None
    if limit is not None and len(limit.path) > 1:
        # The multipliers say the open limits pull; the continuation must agree: no gain
        # beyond rounding when moving closer means the optimum is attained inside.
        gain = limit.path[0]["objective"] - limit.path[-1]["objective"]
        if gain <= 1e-13 * max(1.0, abs(best.objective)):
            limit = None
    open_boundary = best.open_active if limit is not None else ()
    x = best.x
    analysis = analyze(x[0], x[1], x[2], scale)
    qs = _numpy_quantities(x[None, :])
    sim_error = simulation_check(analysis) if verify else None
    if limit is None:
        status = "optimal"
        message = (
            f"optimal (local, the best of {len(solves)} IPOPT solves over "
            f"{len(set(s.region for s in solves))} regions; IPOPT {best.ipopt_status})"
        )
    else:
        status = "not-attained"
        message = _not_attained_message(problem, limit, best)
    if sim_error is not None and not sim_error <= 1e-6:
        message += f"; WARNING: simulation disagrees (relative error {sim_error:.3g})"
    return DesignResult(
        status=status,
        beta=float(x[0]),
        theta_II=float(x[1]),
        phi0=float(x[2]),
        analysis=analysis,
        objective=best.objective,
        cost_of_transport=float(qs["cost_of_transport"][0]),
        step_frequency=float(qs["step_frequency"][0]),
        active_constraints=tuple(_active(problem, best)),
        open_boundary=open_boundary,
        limit=limit,
        simulation_rel_error=sim_error,
        message=message,
        ipopt_status=best.ipopt_status,
        region=_REGIONS[best.region].name,
        **common,
    )


def _speed_beyond_reach(
    targets: Mapping[str, float] | None,
    bounds: Mapping[str, tuple[float | None, float | None]] | None,
    fixed: Mapping[str, float] | None,
    min_contact_margin: float,
    max_eigenvalue: float | None,
    scale: RobotScale | None,
    conditions: str,
    n_starts: int,
) -> str | None:
    """Why a speed target is out of reach, when it is: above the largest speed (the
    supremum of ``--maximize speed``) under the request's other constraints."""
    targets = dict(targets or {})
    key = next((k for k in ("speed", "speed_m_s") if k in targets), None)
    if key is None:
        return None
    wanted = targets.pop(key)
    top = design("speed", targets, bounds, fixed, min_contact_margin, max_eigenvalue, scale,
                 conditions=conditions, n_starts=n_starts, verify=False,
                 explain_infeasible=False)  # fmt: skip
    if top.status not in ("optimal", "not-attained") or top.analysis is None:
        return None
    fastest = float(top.to_dict()[key])
    supremum = None
    if top.limit is not None and top.limit.objective is not None:
        supremum = -top.limit.objective  # the objective minimised is -speed
        if key == "speed_m_s" and scale is not None:
            supremum *= math.sqrt(scale.gravity * scale.leg_length)
    reach = max(fastest, supremum or fastest)
    if not wanted > reach * (1 + 1e-6):
        return None
    unit = " m/s" if key == "speed_m_s" else " sqrt(g r_e)"
    limit = (f" (the supremum, {supremum:.6g}{unit}, is not attained)"
             if top.status == "not-attained" and supremum is not None else "")  # fmt: skip
    return (
        f"the target speed {wanted:g}{unit} is above the fastest gait within the other "
        f"constraints, {fastest:.6g}{unit}{limit}"
    )
