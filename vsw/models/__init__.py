"""The models of the runtime: one object per generated package, every command through it.

``generated.MODELS`` lists the packages ``python -m derive`` writes; :func:`load` gives
each as a :class:`vsw.models.base.Model` (the generic runtime, driven by the package's
``HYBRID`` descriptor, with the commands' interface) or, where a model has closed forms of
its own, as that model's extension of it (the ILE: :class:`vsw.models.ile.model.IleModel`),
which answers the same calls through its closed forms. Names are the packages' keys with
``-`` or ``_`` (``rimless-wheel`` and ``rimless_wheel`` alike). A name ending in ``.py``
is a model file of the user's, and a name no built-in model has may be a package's entry
point (:mod:`vsw.models.user`): their key is the file's absolute path.
"""

from __future__ import annotations

import functools
import importlib
from pathlib import Path

import generated
from vsw.models.base import Model
from vsw.models.user import entry_point_file, is_model_file, model_file, package
from vsw.runtime.errors import VswInputError

__all__ = ["cli_name", "key", "keys", "load"]

EXTENSIONS = {"ile": "vsw.models.ile.model:IleModel"}
"""Models whose closed forms extend the generic runtime, by package key: the class as
``module:name``, imported when its model is loaded (a command on another model imports none
of the ILE's closed forms)."""


def keys() -> tuple[str, ...]:
    """The generated model packages (``generated.<key>``), in the order derive lists them."""
    return tuple(generated.MODELS)


def cli_name(model_key: str) -> str:
    """A model's name on the command line: ``rimless_wheel`` -> ``rimless-wheel``."""
    return model_key.replace("_", "-")


def key(name: str) -> str:
    """The package key of a model name (``-`` and ``_`` alike), or the absolute path of a
    model file (given, or an installed package's entry point), or a one-line refusal."""
    if is_model_file(name):
        return str(model_file(name))
    model_key = name.strip().replace("-", "_")
    if model_key not in keys():
        path = entry_point_file(name.strip())
        if path is not None:
            return str(path)
        names = ", ".join(cli_name(k) for k in keys())
        raise VswInputError(
            f"model {name!r} is not one of {names}, nor a model file (path/to/model.py)"
        )
    return model_key


def load(name: str) -> Model:
    """The model ``name``: one object per model and process."""
    return _load(key(name))


@functools.cache
def _load(model_key: str) -> Model:
    if is_model_file(model_key):
        return Model(package(Path(model_key)))
    module, _, name = EXTENSIONS.get(model_key, "vsw.models.base:Model").partition(":")
    cls = getattr(importlib.import_module(module), name)
    return cls(importlib.import_module(f"generated.{model_key}"))
