"""Results as strict JSON: numpy values to Python's, NaN and infinities to null."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["clean"]


def clean(value: Any) -> Any:
    """Nested dicts/lists of numbers for strict JSON: numpy scalars and arrays to Python
    values, NaN and infinities to None."""
    if isinstance(value, Mapping):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return clean(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, complex):
        return [clean(value.real), clean(value.imag)]
    return value
