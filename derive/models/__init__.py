"""The models the engine derives; each module holds one model's facts and derivation.

``MODELS`` is built on first use (PEP 562), so that importing one model's module (``python
-m derive --model NAME``) does not import, and derive, every other model's module.
"""

import importlib
from collections.abc import Callable
from typing import Any

from derive.registry import MODEL_MODULES


def __getattr__(name: str) -> dict[str, Callable[[], Any]]:
    if name == "MODELS":
        return {name: importlib.import_module(module).derive
                for name, module in MODEL_MODULES.items()}  # fmt: skip
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
