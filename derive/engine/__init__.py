"""The model engine: declarative hybrid walking models and what they imply.

:mod:`derive.engine.model` holds the description (parameters, coordinates, phases, events,
failures); :mod:`derive.engine.hybrid` derives the mechanics from it;
:func:`model_derivation` turns a model into the :class:`~derive.quantities.Derivation`
the code generator writes as ``generated/<model>/``.
"""

from __future__ import annotations

from derive.engine.hybrid import hybrid_quantities, stride_closed_form
from derive.engine.model import Model
from derive.quantities import CExport, Derivation, Quantity

__all__ = ["model_derivation"]


def model_derivation(model: Model, units: str) -> Derivation:
    """The generated package of a model: the generic runtime's functions, the ``HYBRID``
    descriptor and, where the model allows, the stride map in closed form
    (``stride_map``, ``q_fixed``, ``eigenvalue`` in ``q = rate**2`` just after the step
    event). Its C library (``generated/<model>/c/``) holds the closed form, each phase's
    accelerations and each event's reset."""
    derivation = Derivation(
        model=model.name,
        title=model.title,
        source=model.source,
        parameters=model.parameters,
        units=units,
    )
    quantities, descriptor = hybrid_quantities(model)
    for qty in quantities:
        derivation.add(qty)
    stride = stride_closed_form(model)
    descriptor = dict(descriptor, closed_form=stride is not None)
    if stride is not None:
        params = model.parameter_symbols
        q = _section_variable()
        derivation.add(Quantity(
            "stride_map", (*params, q), stride.slope * q + stride.offset,
            "Stride map in q = (rate just after the step event)**2, in closed form.", None,
            "q of the next step",
        ))  # fmt: skip
        derivation.add(Quantity(
            "q_fixed", params, stride.fixed_point,
            "Fixed point of the stride map in q (the period-one gait).", None, "q^f",
        ))  # fmt: skip
        derivation.add(Quantity(
            "eigenvalue", params, stride.slope,
            "Eigenvalue (slope) of the affine stride map.", None, "lambda",
        ))  # fmt: skip
        derivation.add(Quantity(
            "section_angle", params, stride.section_angle,
            "The coordinate just after the step event (the Poincare section).", None, "angle",
        ))  # fmt: skip
        derivation.facts["stride.slope"] = stride.slope
        derivation.facts["stride.offset"] = stride.offset
    derivation.c_exports = _c_exports(model, stride is not None)
    derivation.constants["HYBRID"] = (
        descriptor,
        "The model for the generic runtime (vsw.hybrid): parameters, coordinates, phases "
        "with their failure guards (conservative: T + V constant), events with their guards "
        "and resets (impact or jump), units.",
    )
    return derivation


def _c_exports(model: Model, closed_form: bool) -> tuple[CExport, ...]:
    """The C library: the closed-form stride map, the flow and the resets (what a
    controller or an external simulator needs to step the model)."""
    params = tuple(p.name for p in model.parameters)
    state = params + tuple(c.name for c in model.coordinates)
    state += tuple(c.rate for c in model.coordinates)
    exports = []
    if closed_form:
        exports += [
            CExport("stride_map", (*params, "q"), "q = rate**2 after the next step event"),
            CExport("q_fixed", params, "fixed point of the stride map in q"),
            CExport("eigenvalue", params, "eigenvalue (slope) of the stride map"),
        ]
    for phase in model.phases:
        exports.append(CExport(
            f"{phase.name}_accelerations", state,
            f"second derivatives of the coordinates in phase {phase.name}",
        ))  # fmt: skip
    for event in model.events:
        exports.append(CExport(
            f"{event.name}_reset", state,
            f"coordinates then rates just after the event {event.name}",
        ))  # fmt: skip
    return tuple(exports)


def _section_variable():
    import sympy as sm

    return sm.Symbol("q", nonnegative=True)
