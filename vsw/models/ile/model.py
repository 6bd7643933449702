"""The ILE as a model of the runtime, answered by its closed forms where it has them."""

from __future__ import annotations

from vsw.hybrid import HybridModel

__all__ = ["IleModel"]


class IleModel(HybridModel):
    """The instantaneous leg extension model: the generic runtime plus its closed forms."""
