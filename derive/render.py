"""Every file ``python -m derive`` writes for a model, from its derivation.

The printers live in their own modules (:mod:`derive.codegen` for Python, C through
CasADi and the batch loops, :mod:`derive.sim_codegen` for the batch simulator's table,
:mod:`derive.js_codegen` for JavaScript); this module only decides which files a model
gets.
"""

from __future__ import annotations

import sys

from derive.codegen import (
    backend_module,
    batch_c_source,
    c_sources,
    header,
    load_module,
    params_module,
    python_module,
)
from derive.js_codegen import js_source
from derive.quantities import Derivation
from derive.sim_codegen import simulator_c_source

__all__ = ["render", "render_shared"]


def render(derivation: Derivation) -> dict[str, str]:
    """One model's package, ``{path relative to generated/: text}`` under ``<model>/``.

    ``__init__.py`` holds the functions (numpy and CasADi from one source),
    ``params.py`` the parameter table, ``c/`` the C library and batch loops the model
    declares (``c_exports``, ``batch``) and, for a model with a ``HYBRID`` descriptor, the
    batch simulator's model table (``c/<model>_sim.c``, :mod:`derive.sim_codegen`).
    """
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
