"""The model engine: declarative hybrid walking models and what they imply.

:mod:`derive.engine.model` holds the description (parameters, coordinates, phases, events,
failures); :mod:`derive.engine.hybrid` derives the mechanics from it;
:func:`model_derivation` turns a model into the :class:`~derive.quantities.Derivation`
the code generator writes as ``generated/<model>/``.
"""

from __future__ import annotations

from derive.engine import node_count, shortcuts
from derive.engine.hybrid import hybrid_quantities, stride_closed_form
from derive.engine.model import Model
from derive.quantities import CExport, Derivation, Quantity

__all__ = ["c_exports", "model_derivation"]

node_count.install()  # sympy's orderings, faster (every derivation imports the engine)
shortcuts.install()  # sympy's answers to two frequent questions, the same, faster


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
    # The explorer page (vsw explore) integrates the walk in the browser with these.
    derivation.js_exports = tuple(qty.name for qty in quantities)
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
    derivation.c_exports = c_exports(model, quantities, closed_form=stride is not None)
    derivation.constants["HYBRID"] = (
        descriptor,
        "The model for the generic runtime (vsw.dynamics.hybrid): parameters, coordinates, phases "
        "with their failure guards (conservative: T + V constant), events with their guards "
        "and resets (impact, jump or continuous), units.",
    )
    return derivation


def c_exports(
    model: Model, quantities: list[Quantity], closed_form: bool = False
) -> tuple[CExport, ...]:
    """A model's C library: with ``closed_form`` the stride map, its fixed point and
    eigenvalue, and always each phase's accelerations and each event's reset among the
    engine's ``quantities`` (:func:`hybrid_quantities`): what a controller or an external
    simulator needs to step the model."""
    params = tuple(p.name for p in model.parameters)
    exports = []
    if closed_form:
        exports += [
            CExport("stride_map", (*params, "q"), "q = rate**2 after the next step event"),
            CExport("q_fixed", params, "fixed point of the stride map in q"),
            CExport("eigenvalue", params, "eigenvalue (slope) of the stride map"),
        ]
    for qty in quantities:
        if qty.name.endswith(("_accelerations", "_reset")):
            exports.append(CExport(qty.name, tuple(a.name for a in qty.args), qty.summary))
    return tuple(exports)


def _section_variable():
    import sympy as sm

    return sm.Symbol("q", nonnegative=True)
