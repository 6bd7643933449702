"""The design's closed-form quantities (numpy or CasADi, from ``generated.ile``), its
constants and tolerances, and the three regions of the parameter space where the apex
margin is one smooth piece."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from generated import ile
from generated.ile.params import PARAMETERS
from vsw.dynamics.quantities import maximised

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

OBJECTIVE_ALIASES = {
    "speed": {"speed": 1.0},
    "maximize_speed": {"speed": 1.0},
    "max_speed": {"speed": 1.0},
    "eigenvalue": {"eigenvalue": 1.0},
    "minimize_eigenvalue": {"eigenvalue": 1.0},
    "cost_of_transport": {"cost_of_transport": 1.0},
    "minimize_cost_of_transport": {"cost_of_transport": 1.0},
    "cot": {"cost_of_transport": 1.0},
}
OBJECTIVE_SIGN = {name: -1.0 if maximised(name) else 1.0 for name in OBJECTIVES}
"""An objective term's sign in the sum minimised, by its sense (:mod:`vsw.dynamics.quantities`)."""

VARIABLES = ("beta", "theta_II", "phi0")
TABLE_LIMITS = {p.name: (p.lower, p.upper) for p in PARAMETERS}
CONDITIONS_BY_NAME = {c[0]: c for c in ile.CONDITIONS}  # name -> (name, eq, strict, status, ...)
_MARGIN_NAMES = tuple(c[0] for c in ile.CONDITIONS)
_PIECE_NAMES = ile.condition_pieces.outputs
TIMING_NAMES = ("step_period", "step_frequency", "speed")
SI_NAMES = ("speed_m_s", "step_length_m", "step_frequency_hz")
SI_QUANTITY = {"speed_m_s": "speed", "step_length_m": "step_length",
                 "step_frequency_hz": "step_frequency"}  # fmt: skip
TARGET_NAMES = ("speed", "q_fixed", "step_length", "step_frequency")
METRIC_BOUNDS = ("step_length", "step_frequency")

# Tolerances of the verification of a returned design (closed forms re-evaluated in numpy).
FEAS_TOL = 1e-8  # constraint rows, relative to max(1, |bound|)
ACTIVE_TOL = 1e-6  # a row within this (relative) of a bound is reported active
MULTIPLIER_TOL = 1e-7  # a multiplier above this (relative) pulls towards the bound
SCAN_POINTS = 8192
TARGET_BAND = 0.05  # scan points within 5 % of every target count as seeds for it

IPOPT_OPTIONS = {
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
IPOPT_SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
IPOPT_INFEASIBLE = ("Infeasible_Problem_Detected", "Restoration_Failed", "Empty_Region")


# --- closed-form quantities (numpy or CasADi) ---------------------------------------------


def closed_form_quantities(beta: Any, theta_II: Any, phi0: Any,
                           timing: bool = True) -> dict[str, Any]:  # fmt: skip
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


def numpy_quantities(x: np.ndarray, timing: bool = True) -> dict[str, np.ndarray]:
    """:func:`closed_form_quantities` on an ``(n, 3)`` array of designs; NaN where undefined."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    with np.errstate(all="ignore"):
        return {
            k: np.broadcast_to(v, x.shape[:1]).astype(float)
            for k, v in closed_form_quantities(x[:, 0], x[:, 1], x[:, 2], timing).items()
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


REGIONS = (
    _Region("theta_II <= 0 (apex crossed in phase III-IV)", "apex_phase_III_IV",
            (-math.inf, 0.0), 0),
    _Region("theta_I <= 0 <= theta_II (apex crossed in phase I-II)", "apex_phase_I_II",
            (0.0, math.inf), +1),
    _Region("theta_I >= 0 (apex never crossed)", None, (-math.inf, math.inf), -1),
)  # fmt: skip


def region_of(x: np.ndarray, qs: Mapping[str, np.ndarray]) -> np.ndarray:
    """Index into REGIONS of each design (theta_II <= 0 first, then the sign of theta_I)."""
    theta_I_negative = qs["theta_I_negative"]  # beta - cos phi0: > 0 when theta_I < 0
    return np.where(x[:, 1] <= 0, 0, np.where(theta_I_negative >= 0, 1, 2))
