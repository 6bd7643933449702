"""JavaScript from the derivation: ``generated/<model>/js/<model>.js``.

The functions a model lists in ``Derivation.js_exports`` are printed from the same staged
expressions (:func:`derive.codegen.staged_cse`) as its numpy and CasADi code, by a printer
that differs from the Python one only where the languages do: powers through ``Math.pow``
or products (JavaScript has no ``-x ** 2``), constants as ``const``, tuples as arrays. The
operations (``be``) have numpy's semantics for plain numbers; Carlson's R_F and the
half-angle ``cos_sin`` are the backend's algorithms. The module wrapper is
``templates/model.js.in``. Node.js runs it in tests (tests/test_js.py) against numpy.
"""

from __future__ import annotations

import json
import string
from pathlib import Path

from derive.codegen import PRINTED, RF_STEPS, BackendPrinter, header, staged_cse
from derive.quantities import Derivation, Quantity

TEMPLATE = Path(__file__).resolve().parent / "templates" / "model.js.in"


class JsPrinter(BackendPrinter):
    """The Python backend printer with JavaScript's powers: ``Math.pow`` where Python
    prints ``**`` (JavaScript rejects ``-x ** 2``)."""

    def _print_power(self, base, exp) -> str:
        return f"Math.pow({self._print(base)}, {self._print(exp)})"


def function_js(qty: Quantity, printer: JsPrinter) -> str:
    printed = PRINTED.get((type(printer), qty, None))
    if printed is not None:
        return printed
    pairs, definitions, reduced = staged_cse(qty)
    args = ", ".join(a.name for a in qty.args)
    eq = f" Eq. {qty.equation}." if qty.equation else ""
    lines = [
        f"/* {qty.summary}{eq} Returns {qty.returns}. */\n",
        f"function {qty.name}({args}) {{\n",
    ]
    for cos_name, sin_name, a in pairs:
        lines.append(f"  const [{cos_name}, {sin_name}] = be.cos_sin({printer.doprint(a)});\n")
    for sym, sub in definitions:
        lines.append(f"  const {sym} = {printer.doprint(sub)};\n")
    body = [printer.doprint(e) for e in reduced]
    if isinstance(qty.expr, tuple):
        lines.append(f"  return [{', '.join(body)}];\n")
    else:
        lines.append(f"  return {body[0]};\n")
    lines.append("}\n")
    return "".join(lines)


def js_source(derivation: Derivation) -> str:
    printer = JsPrinter()
    functions = "\n".join(
        function_js(derivation.quantities[name], printer) for name in derivation.js_exports
    )
    parameters = [
        [p.name, float(p.lower), float(p.upper), p.unit or "", p.description]
        for p in derivation.parameters
    ]
    conditions = [
        [c.name, c.equation, c.strict, c.status, c.physical, c.meaning]
        for c in derivation.conditions
    ]
    template = string.Template(TEMPLATE.read_text())
    return template.substitute(
        header=header(derivation.source, " *"),
        model=derivation.model,
        rf_steps=RF_STEPS,
        parameters=json.dumps(parameters),
        conditions=json.dumps(conditions),
        functions=functions,
        names=", ".join(derivation.js_exports),
        namespace=f"vsw_{derivation.model}",
    )
