"""The ILE as a model of the runtime, answered by its closed forms where it has them."""

from __future__ import annotations

from vsw.models.base import Model

__all__ = ["IleModel"]


class IleModel(Model):
    """The instantaneous leg extension model: the generic runtime plus its closed forms."""
