"""The model interface every command uses: the generic runtime plus what a command asks.

:class:`Model` is :class:`vsw.hybrid.HybridModel` (simulation, the Poincaré map, periodic
orbits, eigenvalues: driven by the generated package alone) with the answers the commands
need in one place: the gaits at a parameter set (:mod:`vsw.gaits`, a scan of the section
and Newton), the model's description (:meth:`Model.describe`: parameters, state, section,
units). A model with closed forms of its own (the ILE) subclasses it and answers the same
calls from them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from vsw import gaits
from vsw.hybrid import HybridModel, Orbit

__all__ = ["Model"]


class Model(HybridModel):
    """A generated model through the one interface of the commands."""

    def search_gaits(
        self, params: Sequence[float], box: Mapping[str, tuple[float, float]] | None = None
    ) -> gaits.GaitSearch:
        """The period-one gaits at ``params`` and how they were searched (:mod:`vsw.gaits`)."""
        return gaits.search(self, params, box=box)

    def fixed_points(self, params: Sequence[float]) -> list[Orbit]:
        """The period-one gaits at ``params`` (sorted by period)."""
        return self.search_gaits(params).gaits

    def describe(self) -> dict[str, Any]:
        """The model as ``vsw models --json`` lists it (filled in by the CLI's layer)."""
        return {"name": self.name.replace("_", "-"), "title": self.title}
