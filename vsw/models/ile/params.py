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
from vsw.dynamics import parameters
from vsw.dynamics.parameters import check_positive
from vsw.runtime.errors import VswInputError

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


def check_parameter(name: str, value: object, table: tuple = PARAMETERS) -> np.ndarray:
    """:func:`vsw.dynamics.parameters.check_parameter` with the ILE's table by default."""
    return parameters.check_parameter(name, value, table)


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
