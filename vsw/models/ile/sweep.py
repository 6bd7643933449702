"""Parameter sweeps of any analysis output over grids of beta, theta_II and phi0."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from generated import ile
from vsw.models.ile.analysis import FIELDS, SI_FIELDS, Analysis, analyze
from vsw.models.ile.params import RobotScale, check_parameter
from vsw.runtime.errors import VswInputError

__all__ = ["OUTPUTS", "Sweep", "sweep"]

OUTPUTS = (
    FIELDS
    + SI_FIELDS
    + tuple(f"margin:{c[0]}" for c in ile.CONDITIONS)
    + tuple(f"holds:{c[0]}" for c in ile.CONDITIONS)
)
"""Names :func:`sweep` accepts: Analysis fields, SI fields (need a scale), and
``margin:<condition>`` / ``holds:<condition>`` for every generated condition."""

_BLOCK = 1 << 18  # grid points per analyze() call: bounds memory and paces the progress bar


@dataclass(frozen=True)
class Sweep:
    """Outputs on the grid ``beta x theta_II x phi0`` (``indexing='ij'``).

    Attributes
    ----------
    beta, theta_II, phi0 : numpy.ndarray
        The 1-D axes, shapes (nb,), (nt,), (np,); angles in rad.
    values : dict of str to numpy.ndarray
        Each of shape (nb, nt, np).
    """

    beta: np.ndarray
    theta_II: np.ndarray
    phi0: np.ndarray
    values: dict[str, np.ndarray]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]


def _extract(analysis: Analysis, name: str) -> np.ndarray:
    if name.startswith(("margin:", "holds:")):
        kind, condition = name.split(":", 1)
        record = analysis.condition(condition)
        return np.asarray(record.value if kind == "margin" else record.holds)
    return np.asarray(getattr(analysis, name))


def sweep(
    outputs: str | Sequence[str],
    beta: Any,
    theta_II: Any,
    phi0: Any,
    scale: RobotScale | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Sweep:
    """Evaluate analysis outputs on the full grid of the three parameter axes.

    Parameters
    ----------
    outputs : str or sequence of str
        Names from :data:`OUTPUTS`.
    beta, theta_II, phi0 : float or array_like
        Axes (scalars become axes of length 1); angles in rad.
    scale : RobotScale, optional
        Required for SI outputs.
    progress : callable, optional
        ``progress(done, total)`` in grid points after each block.

    Returns
    -------
    Sweep
        Values of shape (len(beta), len(theta_II), len(phi0)).

    Raises
    ------
    VswInputError
        Unknown output names, SI outputs without scale, or invalid parameter values.
    """
    names = [outputs] if isinstance(outputs, str) else list(outputs)
    unknown = [n for n in names if n not in OUTPUTS]
    if unknown or not names:
        raise VswInputError(f"unknown sweep output(s) {unknown}; choose from {', '.join(OUTPUTS)}")
    if scale is None and any(n in SI_FIELDS for n in names):
        raise VswInputError("SI outputs need a RobotScale (leg length, mass, gravity)")
    axes = [
        np.atleast_1d(check_parameter(n, v)).astype(float).reshape(-1)
        for n, v in (("beta", beta), ("theta_II", theta_II), ("phi0", phi0))
    ]
    shape = tuple(a.size for a in axes)
    total = int(np.prod(shape))
    values = {
        n: np.empty(total, dtype=bool if n == "walks" or n.startswith("holds:") else float)
        for n in names
    }
    timing = any(n.startswith(("step_period", "speed")) for n in names)
    for start in range(0, total, _BLOCK):
        index = np.arange(start, min(start + _BLOCK, total))
        i_beta, i_theta, i_phi0 = np.unravel_index(index, shape)
        analysis = analyze(axes[0][i_beta], axes[1][i_theta], axes[2][i_phi0], scale, timing=timing)
        for n in names:
            values[n][index] = _extract(analysis, n)
        if progress is not None:
            progress(int(index[-1]) + 1, total)
    return Sweep(
        beta=axes[0],
        theta_II=axes[1],
        phi0=axes[2],
        values={n: v.reshape(shape) for n, v in values.items()},
    )
