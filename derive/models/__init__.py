"""The models the engine derives; each module holds one model's facts and derivation."""

import importlib

from derive.registry import MODEL_MODULES

MODELS = {name: importlib.import_module(module).derive for name, module in MODEL_MODULES.items()}
"""Model name (its ``generated/<name>/`` package) -> callable returning its
:class:`derive.quantities.Derivation` (the modules are named in :mod:`derive.registry`)."""
