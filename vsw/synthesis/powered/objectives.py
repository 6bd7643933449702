"""The costs of a powered gait: the NLP's objective (squared inputs, positive work, cost
of transport, the step map's spectral radius by Jury's rows), the positive work of a
linear power, and the cost the request names as reported."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.dynamics.quantities import evaluate
from vsw.dynamics.quantities import weight as walker_weight
from vsw.orbits.monodromy import characteristic_coefficients, jury_rows
from vsw.runtime.errors import VswInputError
from vsw.synthesis.powered.request import MESH_AGREES, Request, prices_work
from vsw.synthesis.powered.variables import Constraints

__all__ = [
    "named_cost",
    "objective",
    "positive_work_of_linear_power",
    "spectral_radius",
    "stability_rows",
    "works_agree",
]


def stability_rows(monodromy: Any, radius: Any, g: Constraints) -> None:
    """Every eigenvalue of the step map's Jacobian within ``radius``: Jury's conditions
    (:func:`vsw.orbits.monodromy.jury_rows`) on the characteristic polynomial of
    ``monodromy / radius``."""
    import casadi as ca

    count = monodromy.shape[0]
    coefficients = characteristic_coefficients(monodromy, count)
    scaled = [a / radius ** (k + 1) for k, a in enumerate(coefficients)]
    g.add(ca.vertcat(*jury_rows(scaled)), 0.0, math.inf)


def positive_work_of_linear_power(before: Any, after: Any, backend: Any = np) -> Any:
    """The positive work of a power that goes linearly from ``before`` to ``after`` over a
    unit interval, ``integral of max(P, 0)``: their mean where neither is negative,
    ``hi^2 / (2 (hi - lo))`` where they differ in sign (the part past the zero crossing), 0
    where neither is positive. ``backend`` is numpy or casadi (elementwise)."""
    if backend is np:
        hi, lo = np.maximum(before, after), np.minimum(before, after)
        crossing = np.maximum(hi, 0.0) ** 2 / (2 * np.where(lo < 0, hi - lo, 1.0))
        return np.where(lo >= 0, (hi + lo) / 2, crossing)
    hi, lo = backend.fmax(before, after), backend.fmin(before, after)
    crossing = backend.fmax(hi, 0) ** 2 / (2 * backend.if_else(lo < 0, hi - lo, 1))
    return backend.if_else(lo >= 0, (hi + lo) / 2, crossing)


def spectral_radius(jacobian: np.ndarray) -> float:
    """The largest eigenvalue's modulus (inf where the matrix is not finite)."""
    if not np.all(np.isfinite(jacobian)):
        return math.inf
    return float(np.max(np.abs(np.linalg.eigvals(jacobian))))


def works_agree(moved: float, mesh: float, scale: float) -> bool:
    """The work along the re-simulated step and the mesh's agree within the mesh's
    tolerance (:data:`MESH_AGREES` of the larger, or 1e-9 of the weight times the step)."""
    return abs(moved - mesh) <= max(MESH_AGREES * max(abs(moved), abs(mesh)), 1e-9 * scale)


def named_cost(model: HybridModel, p: np.ndarray, request: Request, work: dict,
               step_length: float | None, unpriced: float) -> float:  # fmt: skip
    """The cost the request names, without the regularization the NLP adds to it: for the
    costs that price no work, ``unpriced`` (the squared inputs' integral, the NLP's
    objective; the spectral radius of the collocated step map, measured); else the positive
    work, or that work per weight and step length."""
    if not prices_work(request):
        return unpriced
    positive = sum(w["positive"] for w in work.values())
    facts = {"actuator_work": positive, "energy": positive, "step_length": step_length,
             "weight": walker_weight(model, p)}  # fmt: skip
    return evaluate((request.minimize,), facts)[request.minimize]


def objective(model: HybridModel, request: Request, p: Any, squares: Any, priced: Any,
              step_length: Any, monodromy: Any, radius: Any, scale: Any,
              g: Constraints) -> Any:  # fmt: skip
    """The NLP's cost: the squared inputs' integral (``torque2``); the step map's spectral
    radius, at least :data:`vsw.synthesis.powered.request.STABILITY_MARGIN`, by Jury's rows into
    ``g`` (:func:`stability_rows`); the positive work as priced; or that work per weight
    and step length. The last three plus the regularization (``scale``, known after the
    first stage, times :attr:`Request.regularization` times ``squares``)."""
    if request.minimize == "torque2":
        return squares
    if request.minimize == "eigenvalue":
        stability_rows(monodromy, radius, g)
        return radius + request.regularization * scale * squares
    if request.minimize == "work":
        return priced + request.regularization * scale * squares
    if step_length is None:
        raise VswInputError(f"{model.name} defines no step length: no cost of transport")
    facts = {"energy": priced, "weight": walker_weight(model, p), "step_length": step_length}
    return (evaluate(("cost_of_transport",), facts)["cost_of_transport"]
            + request.regularization * scale * squares)  # fmt: skip
