"""A design request checked and made a problem: its objective's weights, the decision
variables' bounds (closed user bounds or the table's open limits), and every constraint
row (conditions, contact, eigenvalue, metric bounds, targets)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsw.models.ile.design.forms import (
    CLOSED_MARGIN,
    CONDITION_SETS,
    METRIC_BOUNDS,
    OBJECTIVE_ALIASES,
    OBJECTIVES,
    REGIONS,
    SI_NAMES,
    SI_QUANTITY,
    STRICT_MARGIN,
    TABLE_DISTANCE,
    TABLE_LIMITS,
    TARGET_NAMES,
    TIMING_NAMES,
    VARIABLES,
)
from vsw.models.ile.params import RobotScale, check_parameter
from vsw.runtime.errors import VswInputError


@dataclass(frozen=True)
class Constraint:
    """``lower <= quantity <= upper``; an ``open`` lower bound is excluded from the set.

    Open constraints (strict conditions) are imposed as ``quantity >= lower + distance``
    with the distance of their kind scaled by the continuation; they are what makes an
    optimum "not attained".
    """

    name: str  # reported to the user (active / conflicting constraints)
    quantity: str  # key of closed_form_quantities
    lower: float
    upper: float
    user: bool  # a user constraint (relaxed in the conflict analysis)
    relax_key: str = ""  # user constraints with the same key are relaxed together
    open: bool = False


@dataclass
class Problem:
    """A checked design request: objective weights, the variables' bounds and which are
    open table limits, every constraint row, the fixed values, the condition set and the
    regions to solve in."""

    weights: dict[str, float]
    lbx: np.ndarray  # closed bounds (user) or the table limits (open, see table_open)
    ubx: np.ndarray
    table_open: set[tuple[int, int]]  # (variable, side) that are open table limits
    bound_names: dict[tuple[int, int], str]  # (variable, 0 lower / 1 upper) -> user name
    constraints: list[Constraint]
    fixed: dict[str, float]
    conditions: str
    regions: tuple[int, ...]
    request: dict[str, Any]  # the arguments it was built from (see without())

    @property
    def timing(self) -> bool:
        return bool(self.weights.get("speed")) or any(
            c.quantity in TIMING_NAMES for c in self.constraints
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

    def region_constraints(self, region: int) -> list[Constraint]:
        """Every constraint that holds in a region, the apex as the region's piece."""
        spec = REGIONS[region]
        out = list(self.constraints)
        if spec.apex_piece is not None:
            out.append(Constraint("apex", spec.apex_piece, 0.0, math.inf, False, open=True))
        if spec.theta_I_sign > 0 and self.conditions != "paper":
            out.append(Constraint("region", "theta_I_negative", 0.0, math.inf, False))
        elif spec.theta_I_sign < 0:
            out.append(Constraint("region", "theta_I_negative", -math.inf, 0.0, False))
        return out

    def bounds(self, region: int, distance: float) -> tuple[np.ndarray, np.ndarray]:
        """Variable bounds in a region, open table limits kept ``distance`` away."""
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        for i, side in self.table_open:
            if side == 0:
                lbx[i] += TABLE_DISTANCE * distance
            else:
                ubx[i] -= TABLE_DISTANCE * distance
        lo, hi = REGIONS[region].theta_II
        lbx[1], ubx[1] = max(lbx[1], lo), min(ubx[1], hi)
        return lbx, ubx

    def without(self, relax_key: str) -> Problem:
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
                if SI_QUANTITY.get(name, name) == quantity:
                    del request["targets"][name]
        else:
            side = 0 if relax_key.endswith("_min") or relax_key.startswith("min_") else 1
            quantity = relax_key[:-4] if relax_key[-4:] in ("_min", "_max") else relax_key[4:]
            for name, pair in list(request["bounds"].items()):
                if SI_QUANTITY.get(name, name) == quantity:
                    lo, hi = _pair(name, pair)
                    request["bounds"][name] = (None, hi) if side == 0 else (lo, None)
        return build_problem(**request)

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


def _contact_constraints(margin: float) -> list[Constraint]:
    """N >= margin at instants I, II, IV: exactly the stance contact over the step."""
    user = margin > CLOSED_MARGIN
    name = "min_contact_margin" if user else "stance_contact"
    return [
        Constraint(name, piece, max(margin, CLOSED_MARGIN), math.inf, user, name if user else "")
        for piece in ("normal_force_I", "normal_force_II", "normal_force_IV")
    ]


def normalise_objective(objective: Any, has_targets: bool) -> dict[str, float]:
    """The objective as weights of :data:`~vsw.models.ile.design.forms.OBJECTIVES` (a name,
    an alias or a mapping; default: the eigenvalue where a target is given)."""
    if objective is None:
        if not has_targets:
            raise VswInputError(
                "design needs an objective (speed, eigenvalue, cost_of_transport) or a target"
            )
        return {"eigenvalue": 1.0}  # a target alone: the most stable gait that meets it
    if isinstance(objective, str):
        key = objective.strip().lower().replace("-", "_").replace(" ", "_")
        if key not in OBJECTIVE_ALIASES:
            raise VswInputError(
                f"objective = {objective!r} is not one of speed, eigenvalue, cost_of_transport"
            )
        return dict(OBJECTIVE_ALIASES[key])
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
    if name not in SI_NAMES:
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
        lo_t, hi_t = TABLE_LIMITS[name]
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


def _metric_constraints(bounds: Mapping[str, Any], scale: RobotScale | None
                       ) -> tuple[dict[str, list[float]], list[Constraint]]:  # fmt: skip
    """The bounds on step length and step frequency (in the model's units or SI), each
    quantity's interval and its rows."""
    constraints: list[Constraint] = []
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
            constraints.append(Constraint(key, quantity, lo, math.inf, True, key))
        if hi < math.inf:
            key = f"max_{quantity}"
            constraints.append(Constraint(key, quantity, -math.inf, hi, True, key))
    return metric, constraints


def _target_constraints(targets: Mapping[str, float] | None, metric: Mapping[str, list[float]],
                        scale: RobotScale | None) -> list[Constraint]:  # fmt: skip
    """Each target's equality row, checked against the other targets and its own bounds."""
    constraints: list[Constraint] = []
    seen: dict[str, float] = {}
    for name, value in (targets or {}).items():
        if name not in TARGET_NAMES and name not in SI_NAMES:
            raise VswInputError(f"target {name!r} is not one of {TARGET_NAMES + SI_NAMES}")
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
        constraints.append(Constraint(key, quantity, v, v, True, key))
    return constraints


def build_problem(
    weights: dict[str, float],
    targets: Mapping[str, float] | None,
    bounds: Mapping[str, tuple[float | None, float | None]] | None,
    fixed: Mapping[str, float] | None,
    min_contact_margin: float,
    max_eigenvalue: float | None,
    scale: RobotScale | None,
    conditions: str = "exact",
) -> Problem:
    """The problem of a request (:func:`vsw.models.ile.design.design`'s arguments), every
    name and value checked (one-line refusals)."""
    if conditions not in CONDITION_SETS:
        raise VswInputError(f"conditions = {conditions!r} is not one of {CONDITION_SETS}")
    bounds = dict(bounds or {})
    fixed = dict(fixed or {})
    for name in bounds:
        if name not in VARIABLES and name not in METRIC_BOUNDS and name not in SI_NAMES:
            raise VswInputError(
                f"bound on {name!r}: bounds exist for {VARIABLES + METRIC_BOUNDS + SI_NAMES}"
            )
    for name in fixed:
        if name not in VARIABLES:
            raise VswInputError(f"fix {name!r}: only {', '.join(VARIABLES)} can be fixed")
    lbx, ubx, table_open, bound_names, fixed_v = _variable_bounds(bounds, fixed)

    constraints: list[Constraint] = [
        Constraint("q_positive", "q_fixed", 0.0, math.inf, False, open=True),
        Constraint("extension_before_heelstrike", "extension_before_heelstrike", 0.0,
                    math.inf, False, open=True),
        Constraint("extension_reached", "extension_reached", 0.0, math.inf, False, open=True),
    ]  # fmt: skip
    if conditions == "paper":
        for name in ("theta_I_negative", "extension_before_symmetric_contact"):
            constraints.append(Constraint(name, name, 0.0, math.inf, False, open=True))
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
            Constraint("max_eigenvalue", "eigenvalue", -math.inf, v, True, "max_eigenvalue")
        )
    metric, rows = _metric_constraints(bounds, scale)
    constraints += rows
    constraints += _target_constraints(targets, metric, scale)
    # The paper's (15) is theta_I < 0, which rules out the region where theta_I >= 0.
    regions = (0, 1) if conditions == "paper" else (0, 1, 2)
    request = {
        "weights": weights, "targets": dict(targets or {}), "bounds": bounds, "fixed": fixed,
        "min_contact_margin": margin, "max_eigenvalue": max_eigenvalue, "scale": scale,
        "conditions": conditions,
    }  # fmt: skip
    return Problem(weights, lbx, ubx, table_open, bound_names, constraints, fixed_v,
                    conditions, regions, request)  # fmt: skip
