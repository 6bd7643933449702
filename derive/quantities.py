"""Containers shared by every model: parameters, derived quantities, conditions.

A model module (``derive/models/<name>.py``) builds a :class:`Derivation`; the code
generator turns it into ``generated/<name>.py`` and C. Nothing here is model specific.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import sympy as sm


@dataclass(frozen=True)
class Parameter:
    """One row of a model's parameter table.

    The same row creates the sympy symbol for the derivation and, through the code
    generator, the runtime's validation table in ``generated/``.

    Attributes
    ----------
    name : str
        Python identifier, also the sympy symbol name (``beta``, ``theta_II``).
    latex : str
        Symbol as printed in the paper.
    lower, upper : float
        Open interval of valid values (radians for angles).
    reason : str
        Why the bounds hold, with the paper's equation number where it has one.
    description : str
        Meaning.
    assumptions : dict
        sympy assumptions for the symbol.
    cli_degrees : bool
        True for angles, which the command line takes in degrees.
    default : float, optional
        The value used when a user gives none (``vsw models``, ``--model``).
    unit : str
        Unit of the value (``rad``, ``m``, ``1`` for a ratio).
    computed : (float, float), optional
        The closed interval, inside the open one, in which the runtime computes: beyond it
        double precision underflows or overflows, or the dynamics become too stiff to
        integrate in reasonable time, and ``vsw`` refuses the value with
        ``computed_reason``. Default: the whole interval, except for a scale (an interval
        (0, inf)), which is computed within a factor of 1e6 of its default
        (:data:`SCALE_FACTOR`).
    computed_reason : str
        Why the values beyond ``computed`` are refused (what was found to fail there).
    """

    name: str
    latex: str
    lower: float
    upper: float
    reason: str
    description: str
    assumptions: dict = field(default_factory=lambda: {"real": True})
    cli_degrees: bool = False
    default: float | None = None
    unit: str = ""
    computed: tuple[float, float] | None = None
    computed_reason: str = ""

    @property
    def symbol(self) -> sm.Symbol:
        return sm.Symbol(self.name, **self.assumptions)

    def computed_range(self) -> tuple[tuple[float, float], str] | None:
        """The declared ``computed`` interval and its reason, or for a scale the default
        one; None where the whole open interval is computed."""
        if self.computed is not None:
            return (float(self.computed[0]), float(self.computed[1])), self.computed_reason
        if self.lower == 0 and self.upper == float("inf") and self.default:
            low, high = self.default / SCALE_FACTOR, self.default * SCALE_FACTOR
            return (float(f"{low:.3g}"), float(f"{high:.3g}")), SCALE_REASON
        return None


SCALE_FACTOR = 1e6
"""A scale parameter (interval (0, inf)) is computed within this factor of its default."""

SCALE_REASON = (
    "a scale is computed within a factor of 1e6 of its default: the gaits depend on "
    "ratios of the parameters, and far beyond, double precision fails (5e-324 computes "
    "with subnormal numbers, 1e300 overflows)"
)


@dataclass(frozen=True)
class Quantity:
    """A derived quantity, generated as one function ``name(*args)``.

    Attributes
    ----------
    name : str
        Function name in the generated code.
    args : tuple of sympy.Symbol
        Arguments, in order.
    expr : sympy.Expr or tuple of sympy.Expr
        The derived expression(s) in terms of ``args``.
    summary : str
        One line for the docstring.
    equation : str or None
        The paper's equation number, e.g. ``"(10)"``; None for quantities beyond the paper.
    returns : str
        Description of the returned value(s).
    intermediates : tuple of (sympy.Symbol, sympy.Expr)
        Named intermediate values, in order: each expression may use ``args`` and the
        earlier names, and ``expr`` may use all of them. The generator emits one line per
        name, so a model can hand it structure (``cos_theta_I``, ``q_f``) that common
        subexpression elimination would not find in the substituted expressions.
    output_names : tuple of str
        Names of the outputs of a tuple-valued quantity, in order; the generated function
        carries them as its ``outputs`` attribute.
    """

    name: str
    args: tuple[sm.Symbol, ...]
    expr: sm.Expr | tuple[sm.Expr, ...]
    summary: str
    equation: str | None = None
    returns: str = ""
    intermediates: tuple[tuple[sm.Symbol, sm.Expr], ...] = ()
    output_names: tuple[str, ...] = ()

    def explicit(self) -> sm.Expr | tuple[sm.Expr, ...]:
        """``expr`` with every intermediate substituted: in terms of ``args`` only."""
        exprs = list(self.expr) if isinstance(self.expr, tuple) else [self.expr]
        for symbol, value in reversed(self.intermediates):
            exprs = [e.xreplace({symbol: value}) for e in exprs]
        return tuple(exprs) if isinstance(self.expr, tuple) else exprs[0]


@dataclass(frozen=True)
class Condition:
    """An existence condition written as ``margin > 0`` (or ``>= 0``).

    Attributes
    ----------
    name : str
        Identifier, e.g. ``apex``.
    equation : str or None
        The paper's equation number, None for conditions the paper does not state.
    margin : sympy.Expr
        Positive exactly when the condition holds.
    strict : bool
        ``margin > 0`` when True, ``margin >= 0`` when False.
    status : str
        What the derivation shows about the paper's condition: ``exact``,
        ``conservative`` (stricter than the exact one), ``implied`` (follows from the
        others), ``framing`` (a choice of the paper's set-up, not needed to walk) or
        ``missing`` (needed, but not stated by the paper).
    physical : bool
        True when the condition is part of the exact physical set that decides "walks".
    meaning : str
        What it means physically.
    unit : str
        Unit of the margin ("" for a dimensionless one).
    """

    name: str
    equation: str | None
    margin: sm.Expr
    strict: bool
    status: str
    physical: bool
    meaning: str
    unit: str = ""


@dataclass(frozen=True)
class CExport:
    """One function of a model's C library (CasADi's code generator, ``vsw_<model>_<name>``).

    Attributes
    ----------
    name : str
        C name without the prefix; a generated Python function of the same name unless
        ``build`` is given.
    args : tuple of str
        Argument names.
    doc : str
        One line for the C file's header.
    build : callable, optional
        ``build(module, *args)`` -> CasADi expression(s), for exports composed of several
        generated functions (``module`` is the generated Python module).
    """

    name: str
    args: tuple[str, ...]
    doc: str
    build: Callable[..., Any] | None = None


@dataclass
class Derivation:
    """Everything one model derives, ready for code generation and for the audit.

    Attributes
    ----------
    model : str
        Model name, also the generated module name.
    title : str
        Human-readable title.
    source : str
        The derivation module that produced it (goes into generated headers).
    parameters : tuple of Parameter
    quantities : dict of str to Quantity
    conditions : tuple of Condition
    facts : dict of str to sympy.Expr
        Intermediate results kept for tests and the audit (keyed by descriptive name).
    c_exports : tuple of CExport
        The functions of the model's C library (``generated/<model>/c/<model>.{c,h}``);
        none: no C library.
    batch : tuple of str
        Quantities that also get a vectorisable C loop
        (``generated/<model>/c/<model>_batch.c``).
    js_exports : tuple of str
        Quantities also printed as JavaScript (``generated/<model>/js/<model>.js``,
        :mod:`derive.js_codegen`).
    units : str
        One sentence on the units of the generated functions (their module docstring).
    paper : bool
        The quantities cite one paper's equations (docstrings then say "Beyond the paper."
        for those it does not have).
    constants : dict of str to (value, docstring)
        Module constants of the generated package (plain Python values: their ``repr``
        is the source).
    """

    model: str
    title: str
    source: str
    parameters: tuple[Parameter, ...]
    quantities: dict[str, Quantity] = field(default_factory=dict)
    conditions: tuple[Condition, ...] = ()
    facts: dict[str, sm.Expr] = field(default_factory=dict)
    c_exports: tuple[CExport, ...] = ()
    batch: tuple[str, ...] = ()
    js_exports: tuple[str, ...] = ()
    units: str = "Angles in radians."
    paper: bool = False
    constants: dict[str, tuple[Any, str]] = field(default_factory=dict)

    def add(self, quantity: Quantity) -> Quantity:
        if quantity.name in self.quantities:
            raise ValueError(f"quantity {quantity.name!r} derived twice")
        self.quantities[quantity.name] = quantity
        return quantity
