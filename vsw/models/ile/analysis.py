"""Analysis of an ILE gait from the generated closed forms, vectorised over parameter sets.

Everything here evaluates ``generated.ile`` on numpy arrays. Large inputs are evaluated in
chunks: the generated expressions create many temporaries and chunks that fit in the CPU
cache are about twice as fast as one pass over 10^6 elements.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from generated import ile
from vsw.models.ile import kernels
from vsw.models.ile.params import RobotScale, validate
from vsw.runtime.threads import default_threads
from vsw.runtime.vectorize import CHUNK, run_blocks

__all__ = [
    "FIELDS",
    "MARGIN_UNITS",
    "SI_FIELDS",
    "Analysis",
    "ConditionResult",
    "analyze",
    "phase_durations_scipy",
    "step_period_scipy",
]

FIELDS = (
    "q_fixed",
    "omega_I",
    "eigenvalue",
    "theta_I",
    "theta_IV",
    "step_length",
    "step_period",
    "speed",
    "energy_added",
    "energy_lost",
    "contact_margin",
    "q_apex_min",
    "q_liftoff_max",
    "walks",
)
"""Array outputs of :func:`analyze` (each has the broadcast shape of the parameters)."""

SI_FIELDS = (
    "speed_m_s",
    "speed_leg_s",
    "step_period_s",
    "step_length_m",
    "energy_added_J",
    "energy_lost_J",
)
"""Extra outputs when a :class:`~vsw.models.ile.params.RobotScale` is given: the SI values,
each under its own key with the unit in its name. The keys of :data:`FIELDS` never change unit."""

MARGIN_UNITS = dict(ile.CONDITION_UNITS)
"""Unit of each condition margin of ``ile.CONDITIONS`` ("" for dimensionless ratios), as
the derivation states it (``derive/models/ile/closed_form.py``): q - bound in g/r_e, angle
differences in rad, beta - cos(phi0) and the cosine ratio of (13) without unit, the normal
force in m g. The test suite checks them against independent values."""

_COMPILED_MIN_SIZE = 100_000


@dataclass(frozen=True)
class ConditionResult:
    """One existence condition evaluated at the fixed point (from ``ile.CONDITIONS``).

    Attributes
    ----------
    name, equation, status, meaning : str
        From the generated table; ``equation`` is None where the paper has no such condition.
    strict, physical : bool
        ``strict``: margin must be > 0 (else >= 0). ``physical``: part of "walks".
    value : float or numpy.ndarray
        The margin, shape of the parameters; positive when the condition holds.
    holds : bool or numpy.ndarray
    unit : str
        Unit of ``value`` (:data:`MARGIN_UNITS`; angles in rad).
    """

    name: str
    equation: str | None
    strict: bool
    status: str
    physical: bool
    meaning: str
    value: Any
    holds: Any
    unit: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready record ``{name, equation, value, unit, holds, status, physical, meaning}``."""
        return {
            "name": self.name,
            "equation": self.equation,
            "value": jsonable(self.value),
            "unit": self.unit,
            "holds": jsonable(self.holds),
            "status": self.status,
            "physical": self.physical,
            "meaning": self.meaning,
        }


@dataclass(frozen=True)
class Analysis:
    """Results of :func:`analyze`; every numeric field has the broadcast parameter shape.

    Dimensionless unless noted: lengths in r_e, time in sqrt(r_e/g), q in g/r_e, energies in
    m g r_e, with or without ``scale``; the SI values are separate fields with the unit in
    their name. Scalar inputs give numpy scalars.

    Attributes
    ----------
    beta, theta_II, phi0 : float or ndarray
        The validated parameters (radians).
    q_fixed : fixed point q^f of the stride map, eq. (10).
    omega_I : sqrt(q_fixed); NaN where q_fixed <= 0.
    eigenvalue : slope of the stride map, eq. (19).
    theta_I, theta_IV : stance leg angle just after / at heelstrike (rad), eq. (11), (5).
    step_length : distance between footholds.
    step_period : sum of the two swing phase durations at q_fixed; NaN where it does not walk.
    speed : step_length / step_period; NaN where it does not walk.
    energy_added, energy_lost : E_c (20) and E_r (21) at q_fixed.
    contact_margin : min N/(m g) over the step at q_fixed.
    q_apex_min, q_liftoff_max : the feasible interval q_apex_min < q <= q_liftoff_max of q.
    conditions : tuple of ConditionResult in the order of ``ile.CONDITIONS``.
    walks : every physical condition holds.
    scale : RobotScale or None
    speed_m_s, speed_leg_s, step_period_s, step_length_m, energy_added_J, energy_lost_J :
        SI values (None without scale).
    """

    beta: Any
    theta_II: Any
    phi0: Any
    q_fixed: Any
    omega_I: Any
    eigenvalue: Any
    theta_I: Any
    theta_IV: Any
    step_length: Any
    step_period: Any
    speed: Any
    energy_added: Any
    energy_lost: Any
    contact_margin: Any
    q_apex_min: Any
    q_liftoff_max: Any
    walks: Any
    conditions: tuple[ConditionResult, ...] = field(repr=False)
    scale: RobotScale | None = None
    speed_m_s: Any = None
    speed_leg_s: Any = None
    step_period_s: Any = None
    step_length_m: Any = None
    energy_added_J: Any = None
    energy_lost_J: Any = None

    def condition(self, name: str) -> ConditionResult:
        """The condition record called ``name`` (KeyError if there is none)."""
        for c in self.conditions:
            if c.name == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict[str, Any]:
        """The JSON contract of ``vsw analyze --json`` (NaN and infinities become None).

        Returns
        -------
        dict
            Keys of :data:`FIELDS` plus ``beta``, ``theta_II``, ``phi0``, ``conditions`` (list
            of records), ``energy_unit`` (the unit of ``energy_added`` and ``energy_lost``:
            always ``"m g r_e"``), and with a scale :data:`SI_FIELDS` and ``scale``. A key
            never changes unit with the scale: SI values have keys of their own.
            Array fields become (nested) lists.
        """
        out: dict[str, Any] = {
            "beta": jsonable(self.beta),
            "theta_II": jsonable(self.theta_II),
            "phi0": jsonable(self.phi0),
        }
        for name in FIELDS:
            out[name] = jsonable(getattr(self, name))
        out["conditions"] = [c.to_dict() for c in self.conditions]
        out["energy_unit"] = "m g r_e"
        if self.scale is not None:
            for name in SI_FIELDS:
                out[name] = jsonable(getattr(self, name))
            out["scale"] = {
                "leg_length": self.scale.leg_length,
                "mass": self.scale.mass,
                "gravity": self.scale.gravity,
            }
        return out


def jsonable(value: Any) -> Any:
    """numpy scalars/arrays to Python floats/bools/lists with None for NaN and infinities."""
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return jsonable(value[()])
        return [jsonable(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def _holds(margin: np.ndarray, strict: bool) -> np.ndarray:
    """Condition test on a margin; NaN margins never hold."""
    with np.errstate(invalid="ignore"):
        return margin > 0 if strict else margin >= 0


def _compute_chunk(
    beta: np.ndarray,
    theta_II: np.ndarray,
    phi0: np.ndarray,
    timing: bool,
    compiled: bool = False,
) -> dict[str, np.ndarray]:
    """All outputs for 1-D parameter arrays of equal length (compiled: use
    vsw.models.ile.kernels)."""
    out: dict[str, np.ndarray] = {}
    # Invalid square roots and divisions happen by design where a gait does not exist; the
    # results are NaN there and are reported as such, never as a warning.
    with np.errstate(all="ignore"):
        if compiled:
            q_fixed, eigenvalue, *margins = kernels.fixed_point_conditions(
                beta, theta_II, phi0, threads=1
            )
        else:
            q_fixed, eigenvalue, *margins = ile.fixed_point_conditions(beta, theta_II, phi0)
        out["q_fixed"] = q_fixed
        out["omega_I"] = np.where(q_fixed > 0, np.sqrt(np.where(q_fixed > 0, q_fixed, 0.0)), np.nan)
        out["eigenvalue"] = eigenvalue
        out["theta_I"] = ile.theta_I(beta, phi0)
        out["theta_IV"] = ile.theta_IV(beta, phi0)
        out["step_length"] = ile.step_length(beta, phi0)
        walks = np.ones(beta.shape, dtype=bool)
        for (name, _eq, strict, _status, physical, _meaning), margin in zip(
            ile.CONDITIONS, margins
        ):
            margin = np.broadcast_to(margin, beta.shape).astype(float)
            out["margin:" + name] = margin
            holds = _holds(margin, strict)
            out["holds:" + name] = holds
            if physical:
                walks &= holds
        out["walks"] = walks
        out["contact_margin"] = ile.contact_margin(beta, theta_II, phi0, q_fixed)
        out["q_apex_min"] = ile.q_apex_min(beta, theta_II, phi0)
        out["q_liftoff_max"] = ile.q_liftoff_max(beta, theta_II, phi0)
        out["energy_added"] = ile.energy_complement(beta, theta_II, phi0, q_fixed, 1.0, 1.0, 1.0)
        out["energy_lost"] = ile.energy_dissipated(beta, theta_II, phi0, q_fixed, 1.0, 1.0, 1.0)
        step_period = np.full(beta.shape, np.nan)
        if timing and walks.any():
            # The elliptic integrals are the most expensive part; evaluate them only where
            # the gait walks (elsewhere the period is NaN anyway).
            sel = np.flatnonzero(walks)
            tau_I_II, tau_III_IV = ile.phase_durations(
                beta[sel], theta_II[sel], phi0[sel], q_fixed[sel]
            )
            step_period[sel] = tau_I_II + tau_III_IV
        out["step_period"] = step_period
        out["speed"] = out["step_length"] / step_period
    return out


def analyze(
    beta: Any,
    theta_II: Any,
    phi0: Any,
    scale: RobotScale | None = None,
    *,
    timing: bool = True,
) -> Analysis:
    """Analyse the ILE gait for one or many parameter sets.

    Parameters
    ----------
    beta, theta_II, phi0 : float or array_like
        Model parameters (angles in radians), broadcastable to a common shape ``S``.
    scale : RobotScale, optional
        Physical scale; adds the SI fields (:data:`SI_FIELDS`).
    timing : bool
        Compute step period and speed (the elliptic integrals are about half the cost);
        with False they are NaN.

    Returns
    -------
    Analysis
        Every numeric field of shape ``S`` (numpy scalars when ``S == ()``).

    Raises
    ------
    VswInputError
        Invalid parameters (see :func:`vsw.models.ile.params.validate`).
    """
    beta_a, theta_a, phi0_a = validate(beta, theta_II, phi0)
    threads = default_threads()  # checks VSW_THREADS for every size of input
    flat = [np.ascontiguousarray(a).reshape(-1) for a in (beta_a, theta_a, phi0_a)]
    merged = {
        key: values.reshape(beta_a.shape)
        for key, values in _evaluate(flat, timing, threads).items()
    }
    return Analysis(
        beta=_shaped(beta_a.astype(float)),
        theta_II=_shaped(theta_a.astype(float)),
        phi0=_shaped(phi0_a.astype(float)),
        conditions=_conditions(merged),
        scale=scale,
        **{name: _shaped(merged[name]) for name in FIELDS},
        **_si_fields(merged, scale),
    )


def _evaluate(flat: list[np.ndarray], timing: bool, threads: int) -> dict[str, np.ndarray]:
    """Every output of :func:`_compute_chunk` for the 1-D parameter arrays ``flat``,
    evaluated chunk by chunk on ``threads`` threads."""
    n = flat[0].size
    # Outputs are preallocated and filled chunk by chunk: concatenating ~30 arrays of 10^6
    # elements afterwards costs as much as a third of the whole evaluation.
    # The compiled kernels only for large batches: a first build takes a compiler run, and
    # small analyses (the CLI) stay byte-for-byte those of the generated numpy code.
    compiled = n >= _COMPILED_MIN_SIZE and kernels.library() is not None

    def block(start: int) -> dict[str, np.ndarray]:
        part = (a[start : start + CHUNK] for a in flat)
        return _compute_chunk(*part, timing, compiled)

    first = block(0)
    merged = {key: np.empty(n, dtype=values.dtype) for key, values in first.items()}

    def store(start: int, part: dict[str, np.ndarray]) -> None:
        for key, values in part.items():
            merged[key][start : start + CHUNK] = values

    store(0, first)
    starts = range(CHUNK, n, CHUNK)
    if len(starts) > 0:
        # numpy releases the GIL inside operations: blocks run in parallel (vsw.runtime.vectorize).
        run_blocks(lambda start: store(start, block(start)), starts, threads)
    return merged


def _shaped(a: np.ndarray) -> Any:
    """An output as :class:`Analysis` holds it: a numpy scalar for scalar parameters."""
    return a[()] if a.ndim == 0 else a


def _conditions(merged: dict[str, np.ndarray]) -> tuple[ConditionResult, ...]:
    """The records of ``ile.CONDITIONS`` from their evaluated margins and tests."""
    return tuple(
        ConditionResult(
            name=name,
            equation=equation,
            strict=strict,
            status=status,
            physical=physical,
            meaning=meaning,
            value=_shaped(merged["margin:" + name]),
            holds=_shaped(merged["holds:" + name]),
            unit=MARGIN_UNITS[name],
        )
        for name, equation, strict, status, physical, meaning in ile.CONDITIONS
    )


def _si_fields(merged: dict[str, np.ndarray], scale: RobotScale | None) -> dict[str, Any]:
    """The SI values of :data:`SI_FIELDS` at ``scale`` (none without one)."""
    if scale is None:
        return {}
    time_unit = scale.time_unit_s
    energy_unit_J = scale.mass * scale.gravity * scale.leg_length  # m g r_e in J
    with np.errstate(all="ignore"):
        step_period_s = merged["step_period"] * time_unit
        step_length_m = merged["step_length"] * scale.leg_length
        speed_m_s = step_length_m / step_period_s
        return {
            "step_period_s": _shaped(step_period_s),
            "step_length_m": _shaped(step_length_m),
            "speed_m_s": _shaped(speed_m_s),
            "speed_leg_s": _shaped(speed_m_s / scale.leg_length),
            "energy_added_J": _shaped(merged["energy_added"] * energy_unit_J),
            "energy_lost_J": _shaped(merged["energy_lost"] * energy_unit_J),
        }


# --- independent closed form of the step period with SciPy ------------------------------


def _swing_time(
    energy: np.ndarray, theta_a: np.ndarray, theta_b: np.ndarray, leg_ratio: Any
) -> np.ndarray:
    """Time to swing from theta_a to theta_b > theta_a when omega^2 = (2/l)(E - cos theta).

    Legendre form with ``scipy.special.ellipkinc`` (parameter m = k^2 < 1 in both cases):

    * E > 1 (energy above the apex): E - cos t = (E + 1)(1 - m sin^2 psi), psi = pi/2 - t/2,
      m = 2/(E + 1).
    * E <= 1 (segment on one side of the apex): with u = |t|/2 and k^2 = (1 + E)/2,
      cos u = k sin psi turns the integral into sqrt(2) (F(psi_a) - F(psi_b)).

    This is a different reduction and a different special-function implementation from
    the generated Carlson duplication, which is the point of the check.
    """
    from scipy.special import ellipkinc

    energy, theta_a, theta_b = np.broadcast_arrays(energy, theta_a, theta_b)
    prefactor = np.sqrt(np.asarray(leg_ratio, dtype=float) / 2.0)
    with np.errstate(all="ignore"):
        m_over = 2.0 / (energy + 1.0)
        integral_over = (
            2.0
            / np.sqrt(energy + 1.0)
            * (
                ellipkinc(np.pi / 2 - theta_a / 2, m_over)
                - ellipkinc(np.pi / 2 - theta_b / 2, m_over)
            )
        )
        k2 = (1.0 + energy) / 2.0
        k = np.sqrt(k2)
        psi_a = np.arcsin(np.cos(np.abs(theta_a) / 2) / k)
        psi_b = np.arcsin(np.cos(np.abs(theta_b) / 2) / k)
        integral_under = np.sqrt(2.0) * np.abs(ellipkinc(psi_a, k2) - ellipkinc(psi_b, k2))
        # Below the apex energy a segment must not cross theta = 0 and cos theta < E on it.
        same_side = (theta_a * theta_b >= 0) | (energy > 1)
        reachable = (energy > np.cos(theta_a)) | np.isclose(energy, np.cos(theta_a))
        reachable &= energy > np.cos(theta_b)
        integral = np.where(energy > 1, integral_over, integral_under)
        return np.where(same_side & reachable & (theta_b > theta_a), prefactor * integral, np.nan)


def phase_durations_scipy(
    beta: Any, theta_II: Any, phi0: Any, q: Any
) -> tuple[np.ndarray, np.ndarray]:
    """Durations of the swing phases I-II and III-IV from the paper's equations and SciPy.

    Independent of the generated code: theta_I from eq. (11), theta_IV = theta_I + phi0,
    energies from (2)-(4), the extension reset (3), and Legendre's F from
    ``scipy.special.ellipkinc``.

    Parameters
    ----------
    beta, theta_II, phi0, q : float or array_like
        Broadcastable; q = omega_I^2 at instant I.

    Returns
    -------
    tuple of numpy.ndarray
        ``(tau_I_II, tau_III_IV)`` in sqrt(r_e/g); NaN where the phase cannot be completed.
    """
    beta, theta_II, phi0, q = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (beta, theta_II, phi0, q))
    )
    with np.errstate(all="ignore"):
        theta_I = -np.arctan((beta - np.cos(phi0)) / np.sin(phi0))  # eq. (11)
        theta_IV = theta_I + phi0
        # Phase I-II, leg r_s = beta r_e: omega^2 = (2/beta)(E1 - cos theta).
        energy_1 = np.cos(theta_I) + beta * q / 2
        omega_II_sq = (2 / beta) * (energy_1 - np.cos(theta_II))
        omega_III_sq = beta**4 * omega_II_sq  # eq. (3) squared
        # Phase III-IV, leg r_e: omega^2 = 2 (E2 - cos theta).
        energy_2 = np.cos(theta_II) + omega_III_sq / 2
        tau_I_II = _swing_time(energy_1, theta_I, theta_II, beta)
        tau_III_IV = _swing_time(energy_2, theta_II, theta_IV, 1.0)
    return tau_I_II, tau_III_IV


def step_period_scipy(beta: Any, theta_II: Any, phi0: Any, q: Any) -> np.ndarray:
    """Step period tau_I_II + tau_III_IV from :func:`phase_durations_scipy`.

    Parameters
    ----------
    beta, theta_II, phi0, q : float or array_like
        Broadcastable.

    Returns
    -------
    numpy.ndarray
        Step period in sqrt(r_e/g); NaN where a phase cannot be completed.
    """
    tau_I_II, tau_III_IV = phase_durations_scipy(beta, theta_II, phi0, q)
    return tau_I_II + tau_III_IV
