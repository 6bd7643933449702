"""The models the engine derives; each module holds one model's facts and derivation."""

from derive.models import ile

MODELS = (ile.derive,)
"""Callables returning a :class:`derive.quantities.Derivation`, one per model."""
