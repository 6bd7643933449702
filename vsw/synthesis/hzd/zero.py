"""The hybrid zero dynamics of a model under virtual constraints: the restricted Poincaré
map, its fixed point and stability, the gait on the surface and its torques.

The constraints' package (:mod:`derive.hzd`, generated) gives, as functions of the phase
``theta``: the surface ``Phi`` and its derivatives, ``I(theta)`` (``sigma = I theta_dot``,
``sigma`` the angular momentum about the stance foot), ``kappa(theta) = d zeta/d theta``
(``zeta = sigma^2/2``) and ``delta = sigma_+/sigma_-`` through the impact. Here
(Westervelt, Grizzle & Koditschek 2003, IEEE TAC 48(1), Section IV-B, eqs. (58)-(61)):

* ``V(theta) = -integral_{theta_+}^{theta} kappa``, by Fejér's first rule: ``kappa``
  interpolated at :data:`NODES` Chebyshev points of the first kind on ``[theta_+,
  theta_-]`` and the interpolant integrated exactly; the error is estimated by the same
  rule on half the points (``quadrature_error``: for the smooth integrands of a rigid
  walker the rule converges geometrically, and the estimate bounds the error of the half
  rule);
* the restricted map on ``zeta_-`` (just before the impact): ``zeta_{k+1} = delta^2 zeta_k
  - V(theta_-)``; fixed point ``zeta* = -V(theta_-)/(1 - delta^2)``, exponentially stable
  when ``delta^2 < 1``; it exists as a walk when ``zeta(theta) = delta^2 zeta* - V(theta)``
  stays positive over the step (``delta^2 zeta* > max V``);
* the step's duration ``integral I(theta)/sqrt(2 zeta(theta)) d theta`` by the same rule.

Imports numpy only; the model and the constraints are taken as their generated modules.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import chebyshev

from vsw.runtime.errors import ModelConditionError, VswInputError

__all__ = ["NODES", "Surface", "ZeroDynamics", "chebyshev_integral", "zero_dynamics"]

NODES = 96
"""Chebyshev points of the quadrature (the estimate uses half as many)."""


def chebyshev_integral(f: Callable[[np.ndarray], np.ndarray], lo: float, hi: float,
                       nodes: int = NODES) -> chebyshev.Chebyshev:  # fmt: skip
    """The indefinite integral from ``lo`` of ``f``'s Chebyshev interpolant on [lo, hi]
    (``nodes`` points of the first kind), a Chebyshev series in theta."""
    series = chebyshev.Chebyshev.interpolate(f, nodes - 1, domain=[lo, hi])
    return series.integ(lbnd=lo)


class Surface:
    """The constraint surface and the outputs of a constraints package at a parameter set
    and a vector of Bezier coefficients (the impact-invariant ones filled in)."""

    def __init__(self, package, params: Sequence[float], alphas: Sequence[float]) -> None:
        spec = package.HZD
        self.package = package
        self.params = tuple(float(v) for v in params)
        self.alphas = tuple(float(v) for v in alphas)
        self.theta_plus = float(spec["theta_plus"])
        self.theta_minus = float(spec["theta_minus"])
        self.n = len(spec["coordinates"])
        self.k = len(spec["outputs"])
        self.controlled = np.array([row for row, _ in spec["controlled"]], float)
        self.offsets = np.array([c for _, c in spec["controlled"]], float)
        self.phase_row = np.array(spec["phase_row"][:-1], float)
        self.phase_offset = float(spec["phase_row"][-1])

    def _args(self, theta) -> tuple:
        return (*self.params, *self.alphas, theta)

    def at(self, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, dq/dtheta, d2q/dtheta2 at ``theta`` (arrays (n, ...))."""
        out = np.array(np.broadcast_arrays(*self.package.surface(*self._args(theta))), float)
        return out[: self.n], out[self.n : 2 * self.n], out[2 * self.n :]

    def desired(self, theta):
        """h, dh/dtheta, d2h/dtheta2 (each a tuple of one per output; any backend)."""
        out = self.package.desired(*self._args(theta))
        return out[: self.k], out[self.k : 2 * self.k], out[2 * self.k :]

    def zero(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """I(theta) and kappa(theta)."""
        inertia, kappa, _ = self.package.zero_dynamics(*self._args(theta))
        shape = np.shape(theta)
        return np.broadcast_to(inertia, shape) * 1.0, np.broadcast_to(kappa, shape) * 1.0

    def impact_ratio(self) -> tuple[float, float]:
        delta, inertia = self.package.impact_ratio(*self._args(self.theta_minus))
        return float(delta), float(inertia)

    def phase(self, q) -> float:
        return float(self.phase_row @ np.asarray(q, float) + self.phase_offset)

    def output_rates(self, q, qd) -> np.ndarray:
        """y_dot = (a' - h'(theta) c) q_dot: the outputs' rates at a state."""
        theta = self.phase(q)
        _, dh, _ = self.desired(theta)
        theta_dot = float(self.phase_row @ qd)
        return self.controlled @ qd - np.array(dh, float) * theta_dot

    def outputs(self, q) -> np.ndarray:
        h, _, _ = self.desired(self.phase(q))
        return self.controlled @ np.asarray(q, float) + self.offsets - np.array(h, float)


@dataclass(frozen=True)
class ZeroDynamics:
    """The restricted Poincaré map's numbers (see the module docstring)."""

    delta: float
    potential: chebyshev.Chebyshev  # V(theta)
    v_minus: float
    v_max: float
    theta_at_max: float
    zeta_star: float
    inertia_minus: float
    inertia_plus: float
    quadrature_error: float
    period: float

    @property
    def delta_squared(self) -> float:
        return self.delta**2

    @property
    def theta_dot_minus(self) -> float:
        return float(np.sqrt(2 * self.zeta_star)) / self.inertia_minus

    @property
    def theta_dot_plus(self) -> float:
        return self.delta * float(np.sqrt(2 * self.zeta_star)) / self.inertia_plus

    def zeta(self, theta) -> np.ndarray:
        """zeta along the gait: delta^2 zeta* - V(theta)."""
        return self.delta_squared * self.zeta_star - self.potential(theta)


def _check_monotonic(surface: Surface) -> tuple[float, float]:
    """I(theta) keeps the sign of theta_minus - theta_plus over the step (theta_dot then
    keeps its sign while sigma does), checked at 2001 points and the interpolant's roots."""
    lo, hi = surface.theta_plus, surface.theta_minus
    grid = np.linspace(lo, hi, 2001)
    inertia, _ = surface.zero(grid)
    sense = np.sign(hi - lo)
    signs = np.sign(inertia * sense)
    if np.any(signs > 0) and np.any(signs <= 0):
        # I = B_perp D Phi' vanishes: D Phi' is in the range of B, so an input moves the
        # walker along the surface and L_g L_f y (= J D^-1 B, J Phi' = 0) is singular.
        where = grid[np.argmax(signs != signs[0])]
        raise VswInputError(
            f"the decoupling matrix L_g L_f y is singular on the surface at theta = "
            f"{where:.6g}: I(theta), sigma per unit theta_dot, changes sign there"
        )
    if np.all(signs <= 0):
        raise VswInputError(
            f"the phase variable is not monotonic from theta_plus to theta_minus along a "
            f"step that walks forward: I(theta) (sigma per unit theta_dot) is "
            f"{'negative' if sense > 0 else 'positive'}, so theta would run back from "
            f"{lo:.6g} (declare theta_plus, theta_minus and the phase in the walking sense)"
        )
    return float(inertia[-1]), float(inertia[0])


def zero_dynamics(surface: Surface) -> ZeroDynamics:
    """The restricted map's fixed point and stability (ModelConditionError: no walking gait
    on the surface)."""
    lo, hi = surface.theta_plus, surface.theta_minus
    inertia_minus, inertia_plus = _check_monotonic(surface)

    def kappa(t: np.ndarray) -> np.ndarray:
        return -surface.zero(t)[1]

    potential = chebyshev_integral(kappa, lo, hi)
    coarse = chebyshev_integral(kappa, lo, hi, NODES // 2)
    error = abs(float(potential(hi) - coarse(hi)))
    delta, _ = surface.impact_ratio()
    v_minus = float(potential(hi))
    critical = potential.deriv().roots()
    inside = [c for c in critical if abs(c.imag) < 1e-12 and min(lo, hi) < c.real < max(lo, hi)]
    candidates = [lo, hi, *(float(c.real) for c in inside)]
    values = [float(potential(c)) for c in candidates]
    top = int(np.argmax(values))
    d2 = delta * delta
    if not delta > 0.0:
        raise ModelConditionError(
            f"the impact turns the walker back: delta = {delta:.6g} <= 0 (the angular "
            "momentum about the new stance foot after the impact is not that before it in "
            "sign), so no step follows"
        )
    if not d2 < 1.0:
        raise ModelConditionError(
            f"the restricted map has no stable fixed point: delta^2 = {d2:.6g} >= 1 (the "
            "impact gains angular momentum; Westervelt et al. 2003, (61))"
        )
    zeta_star = -v_minus / (1.0 - d2)
    if not (zeta_star > 0 and d2 * zeta_star > values[top]):
        raise ModelConditionError(
            f"no gait on the zero dynamics: zeta reaches 0 within the step (the walker stops "
            f"and falls back): delta^2 zeta* = {d2 * zeta_star:.6g} but max V = "
            f"{values[top]:.6g} at theta = {candidates[top]:.6g} (Westervelt et al. 2003, (62))"
        )

    def slowness(t: np.ndarray) -> np.ndarray:
        zeta = d2 * zeta_star - potential(t)
        return surface.zero(t)[0] / np.sqrt(2.0 * zeta)

    period = float(chebyshev_integral(slowness, lo, hi)(hi))
    return ZeroDynamics(delta, potential, v_minus, values[top], candidates[top], zeta_star,
                        inertia_minus, inertia_plus, error, period)  # fmt: skip
