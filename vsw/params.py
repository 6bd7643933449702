"""Validated gait parameters and robot scales.

The bounds and their reasons come from ``generated/ile/params.py::PARAMETERS``, the single
parameter table that also creates the symbols of the derivation; nothing is retyped here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Real

import numpy as np

from generated.ile.params import PARAMETERS
from vsw.errors import VswInputError

__all__ = [
    "PARAMETER_BY_NAME",
    "STEPPER_2D",
    "GaitParameters",
    "RobotScale",
    "check_parameter",
    "check_positive",
    "validate",
]

PARAMETER_BY_NAME = {p.name: p for p in PARAMETERS}
"""The generated parameter table keyed by name (``beta``, ``theta_II``, ``phi0``)."""


def _format_value(value: object, cli_degrees: bool) -> str:
    """A short human form of a scalar value; angles also in degrees (the CLI's unit)."""
    if isinstance(value, (float, np.floating)) and cli_degrees and math.isfinite(value):
        return f"{value:.6g} rad ({math.degrees(value):.6g} deg)"
    if isinstance(value, (float, np.floating)):
        return f"{value:.6g}"
    return repr(value)


def _as_float_array(name: str, value: object, reason: str) -> np.ndarray:
    """``value`` as a float array; anything that is not a real number raises VswInputError."""
    # bool is an int subclass and strings convert with dtype=float: both are rejected on purpose.
    if isinstance(value, np.ma.MaskedArray) and np.ma.getmaskarray(value).any():
        # np.asarray would silently drop the mask and compute with the hidden values.
        count = int(np.ma.getmaskarray(value).sum())
        raise VswInputError(
            f"{name} is a masked array with {count} masked value(s), which would be computed "
            f"as if unmasked; pass the values to use, e.g. {name}.compressed() or "
            f"{name}.filled(...)"
        )
    raw = np.asarray(value)
    if raw.dtype.kind not in "iuf":
        raise VswInputError(f"{name} = {value!r} is not a real number; {reason}")
    return raw.astype(float, copy=False)


def check_parameter(name: str, value: object, table: tuple | None = None) -> np.ndarray:
    """Validate one model parameter against the open interval of the generated table.

    Parameters
    ----------
    name : str
        Parameter name as in the table (the ILE's: ``beta``, ``theta_II``, ``phi0``).
    value : float or array_like
        Value(s) in radians for angles.
    table : tuple of generated Parameter records, optional
        Another model's table (``generated.<model>.params.PARAMETERS``); default the ILE's.

    Returns
    -------
    numpy.ndarray
        ``value`` as a float array of the same shape.

    Raises
    ------
    VswInputError
        One line naming the parameter, the first offending value and the violated condition
        with the table's reason (which cites the paper's equation where there is one).
    """
    p = PARAMETER_BY_NAME[name] if table is None else next(r for r in table if r.name == name)
    arr = _as_float_array(name, value, p.reason)
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(arr) & (arr > p.lower) & (arr < p.upper))
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0]) if arr.ndim else ()
        where = f"{name}[{', '.join(map(str, index))}]" if index else name
        bad_value = float(arr[index])
        shown = _format_value(bad_value, p.cli_degrees)
        if not math.isfinite(bad_value):
            condition = "must be finite"
        else:
            condition = f"violates {p.lower:.6g} < {name} < {p.upper:.6g}"
        raise VswInputError(f"{where} = {shown} {condition}: {p.reason}")
    return arr


def check_positive(name: str, value: object, reason: str) -> np.ndarray:
    """Validate a positive finite quantity (a scale, q0, ...); same error style as parameters.

    Parameters
    ----------
    name : str
        Name used in the message.
    value : float or array_like
    reason : str
        Why it must be positive (appended to the message).

    Returns
    -------
    numpy.ndarray
    """
    arr = _as_float_array(name, value, reason)
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(arr) & (arr > 0))
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0]) if arr.ndim else ()
        bad_value = float(arr[index])
        condition = "must be finite" if not math.isfinite(bad_value) else "must be > 0"
        raise VswInputError(f"{name} = {bad_value:.6g} {condition}: {reason}")
    return arr


def validate(beta: object, theta_II: object, phi0: object) -> tuple[np.ndarray, ...]:
    """Validate (beta, theta_II, phi0), scalars or arrays, and broadcast them.

    Parameters
    ----------
    beta, theta_II, phi0 : float or array_like
        Broadcastable against each other; angles in radians.

    Returns
    -------
    tuple of numpy.ndarray
        ``(beta, theta_II, phi0)`` as float arrays of the common broadcast shape.

    Raises
    ------
    VswInputError
        Non-numbers, NaN, infinities, values outside the open interval of the parameter
        table, or shapes that do not broadcast.
    """
    arrays = [check_parameter(n, v) for n, v in zip(PARAMETER_BY_NAME, (beta, theta_II, phi0))]
    try:
        return tuple(np.broadcast_arrays(*arrays))
    except ValueError:
        shapes = ", ".join(f"{n}{a.shape}" for n, a in zip(PARAMETER_BY_NAME, arrays))
        raise VswInputError(f"parameter shapes do not broadcast: {shapes}") from None


@dataclass(frozen=True)
class GaitParameters:
    """One validated parameter set of the ILE model; angles in radians.

    Attributes
    ----------
    beta : float
        Length shorten ratio r_s / r_e, 0 < beta < 1.
    theta_II : float
        Stance leg angle at the leg extension (instant II), |theta_II| < pi/2.
    phi0 : float
        Inter-leg angle at heelstrike, 0 < phi0 < pi/2 (eq. 16).
    """

    beta: float
    theta_II: float
    phi0: float

    def __post_init__(self) -> None:
        for name in ("beta", "theta_II", "phi0"):
            value = getattr(self, name)
            if not isinstance(value, Real) or isinstance(value, bool):
                p = PARAMETER_BY_NAME[name]
                raise VswInputError(f"{name} = {value!r} is not a real number; {p.reason}")
            check_parameter(name, value)
            object.__setattr__(self, name, float(value))

    @classmethod
    def from_degrees(cls, beta: float, theta_II_deg: float, phi0_deg: float) -> GaitParameters:
        """Build from angles in degrees (the CLI's unit)."""
        for name, value in (("theta_II", theta_II_deg), ("phi0", phi0_deg)):
            if not isinstance(value, Real) or isinstance(value, bool):
                p = PARAMETER_BY_NAME[name]
                raise VswInputError(f"{name} = {value!r} is not a real number; {p.reason}")
        return cls(beta, math.radians(theta_II_deg), math.radians(phi0_deg))

    def astuple(self) -> tuple[float, float, float]:
        """``(beta, theta_II, phi0)``, the argument order of every generated function."""
        return (self.beta, self.theta_II, self.phi0)


@dataclass(frozen=True)
class RobotScale:
    """Physical scale that turns dimensionless results into SI units.

    Attributes
    ----------
    leg_length : float
        Extended leg length r_e in m.
    mass : float
        Point mass m in kg.
    gravity : float
        Gravitational acceleration g in m/s^2.
    """

    leg_length: float
    mass: float
    gravity: float = 9.81

    def __post_init__(self) -> None:
        reasons = {
            "leg_length": "the extended leg length r_e in m is the unit of length",
            "mass": "the point mass m in kg scales the energies",
            "gravity": "g in m/s^2 sets the time unit sqrt(r_e/g)",
        }
        for name, reason in reasons.items():
            value = getattr(self, name)
            if not isinstance(value, Real) or isinstance(value, bool):
                raise VswInputError(f"{name} = {value!r} is not a real number; {reason}")
            check_positive(name, value, reason)
            object.__setattr__(self, name, float(value))

    @property
    def time_unit_s(self) -> float:
        """The dimensionless time unit sqrt(r_e / g) in seconds."""
        return math.sqrt(self.leg_length / self.gravity)


STEPPER_2D = RobotScale(leg_length=0.25, mass=0.78, gravity=9.81)
"""The Stepper-2D prototype of the paper: two 12.5 cm leg segments, 780 g."""


def random_parameters(
    n: int, seed: int = 0, *, walking: bool = False, margin: float = 1e-3
) -> dict[str, np.ndarray]:
    """Seeded random parameter sets: uniform in the parameter table's domain, or walking.

    Parameters
    ----------
    n : int
        Number of sets.
    seed : int
        Seed of ``numpy.random.default_rng``; the same seed gives the same sets.
    walking : bool
        Keep only sets at which every physical existence condition holds (with a margin
        of 1e-6), drawing more until there are ``n``.
    margin : float
        Keep this fraction of each parameter's range away from its open bounds.

    Returns
    -------
    dict of str to numpy.ndarray
        ``beta``, ``theta_II``, ``phi0`` (radians), each of shape ``(n,)``.

    Examples
    --------
    >>> sets = random_parameters(3, seed=1, walking=True)
    >>> sorted(sets), sets["beta"].shape
    (['beta', 'phi0', 'theta_II'], (3,))
    """
    if not walking:
        rng = np.random.default_rng(seed)
        out = {}
        for p in PARAMETERS:
            width = p.upper - p.lower
            out[p.name] = rng.uniform(p.lower + margin * width, p.upper - margin * width, n)
        return out
    from generated import ile

    physical = [i for i, c in enumerate(ile.CONDITIONS) if c[4]]
    picked: dict[str, list[np.ndarray]] = {p.name: [] for p in PARAMETERS}
    count, batch_seed = 0, seed
    while count < n:
        draw = random_parameters(4 * n, batch_seed, margin=margin)
        batch_seed += 1000
        with np.errstate(all="ignore"):
            margins = ile.condition_margins(draw["beta"], draw["theta_II"], draw["phi0"])
        ok = np.ones(4 * n, dtype=bool)
        for i in physical:
            m = np.broadcast_to(margins[i], ok.shape)
            ok &= (m > 1e-6) if ile.CONDITIONS[i][2] else (m >= 1e-6)
        for name in picked:
            picked[name].append(draw[name][ok])
        count += int(ok.sum())
    return {name: np.concatenate(v)[:n] for name, v in picked.items()}
