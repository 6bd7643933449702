"""Every file ``python -m derive`` writes for a model, from its derivation.

The printers live in their own modules (:mod:`derive.codegen` for Python, C through
CasADi and the batch loops, :mod:`derive.sim_codegen` for the batch simulator's table,
:mod:`derive.js_codegen` for JavaScript); this module only decides which files a model
gets.
"""

from __future__ import annotations

import sys

from derive.codegen import (
    PRINTED,
    BackendPrinter,
    backend_module,
    batch_c_source,
    c_sources,
    function_source,
    header,
    load_module,
    params_module,
    python_module,
)
from derive.js_codegen import JsPrinter, function_js, js_source
from derive.quantities import Derivation, Quantity
from derive.sim_codegen import simulator_c_source
from derive.workers import map_in_workers

__all__ = ["print_ahead", "render", "render_shared"]


def render(derivation: Derivation, workers: int = 1) -> dict[str, str]:
    """One model's package, ``{path relative to generated/: text}`` under ``<model>/``.

    ``__init__.py`` holds the functions (numpy and CasADi from one source),
    ``params.py`` the parameter table, ``c/`` the C library and batch loops the model
    declares (``c_exports``, ``batch``) and, for a model with a ``HYBRID`` descriptor, the
    batch simulator's model table (``c/<model>_sim.c``, :mod:`derive.sim_codegen`).
    With ``workers`` > 1 the functions are printed in that many forked processes first
    (:func:`print_ahead`); the files are the same.
    """
    if workers > 1:
        print_ahead(derivation, workers)
    name = derivation.model
    py = python_module(derivation)
    files = {f"{name}/__init__.py": py, f"{name}/params.py": params_module(derivation)}
    hybrid = derivation.constants.get("HYBRID")
    if derivation.c_exports or hybrid:
        # The C path is built from the very source that is written, not from sympy objects.
        backend = load_module("generated._backend", backend_module("derive/codegen.py"))
        saved = sys.modules.get("generated._backend")
        sys.modules["generated._backend"] = backend
        try:
            module = load_module(f"generated.{name}", py)
        finally:
            if saved is None:
                del sys.modules["generated._backend"]
            else:
                sys.modules["generated._backend"] = saved
        if derivation.c_exports:
            c_files = c_sources(derivation, module)
            files.update({f"{name}/{path}": text for path, text in c_files.items()})
        if hybrid:
            files[f"{name}/c/{name}_sim.c"] = simulator_c_source(
                name, derivation.source, hybrid[0], module
            )
    if derivation.batch:
        files[f"{name}/c/{name}_batch.c"] = batch_c_source(derivation)
    if derivation.js_exports:
        files[f"{name}/js/{name}.js"] = js_source(derivation)
    return files


_AHEAD: list[tuple[Quantity, str, bool]] = []
"""What :func:`print_ahead`'s workers print: each quantity with its docstring note and
whether it is exported to JavaScript (set before they fork, read in them)."""

_AHEAD_LEAST = 8
"""Quantities below which a model's functions are printed in the process itself."""


def print_ahead(derivation: Derivation, workers: int) -> None:
    """Print every function of ``derivation`` (Python, and JavaScript where exported) in
    ``workers`` forked processes and keep the texts in :data:`derive.codegen.PRINTED`.

    Eliminating common subexpressions is most of printing a model, each function on its
    own: a model derived alone spreads it over the cores. The largest functions go first
    and each worker takes the next when it is done, so the workers finish together (runs
    of neighbouring functions would share more of sympy's cache, but a model's largest
    functions are few and together). The workers return text, which is what the module
    prints either way. Each worker builds in sympy's cache what the other has built too:
    the TLE's functions take 0.94 s in each of two workers against 1.23 s in one process,
    three quarters of the time for half again the CPU time."""
    quantities = list(derivation.quantities.values())
    if len(quantities) < _AHEAD_LEAST:
        return
    unreferenced = " Beyond the paper." if derivation.paper else ""
    exported = set(derivation.js_exports)
    order = sorted(range(len(quantities)), key=lambda k: -_distinct_nodes(quantities[k]))
    _AHEAD[:] = [(quantities[k], unreferenced, quantities[k].name in exported) for k in order]
    try:
        texts = map_in_workers(_print_one, list(range(len(order))), workers)
    finally:
        _AHEAD.clear()
    for k, (source, js) in zip(order, texts):
        PRINTED[(BackendPrinter, quantities[k], unreferenced)] = source
        if js is not None:
            PRINTED[(JsPrinter, quantities[k], None)] = js


def _print_one(index: int) -> tuple[str, str | None]:
    """A worker's task: the Python (and JavaScript) text of the quantity at ``index``."""
    qty, unreferenced, exported = _AHEAD[index]
    source = function_source(qty, BackendPrinter(), unreferenced)
    return source, function_js(qty, JsPrinter()) if exported else None


def _distinct_nodes(qty: Quantity) -> int:
    """The distinct subexpressions of a quantity's outputs and intermediates: what its
    elimination costs, roughly."""
    outputs = list(qty.expr) if isinstance(qty.expr, tuple) else [qty.expr]
    stack = [value for _, value in qty.intermediates] + outputs
    seen: set = set()
    while stack:
        node = stack.pop()
        if node not in seen:
            seen.add(node)
            stack.extend(getattr(node, "args", ()))
    return len(seen)


def render_shared(derivations: list[Derivation]) -> dict[str, str]:
    """The files every model shares: the package's ``__init__.py`` and the backend."""
    names = tuple(d.model for d in derivations)
    init = (
        header("derive/models/ (every model)", "#")
        + '"""Generated numeric code (numpy, CasADi, C), one package per model. Do not edit: '
        'run `python -m derive`."""\n\n'
        + f"MODELS = {names!r}\n"
        + '"""The generated model packages, ``generated.<name>``."""\n'
    )
    return {"__init__.py": init, "_backend.py": backend_module("derive/codegen.py")}
