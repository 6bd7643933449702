"""Walks of the Poincaré map: the state just after every step event, step by step.

:func:`walk` is what ``vsw simulate`` prints for every model: from a section state, one
simulated step after another (:meth:`vsw.dynamics.hybrid.HybridModel.step`, SciPy DOP853 with the
model's guards as events) until the steps are done or the walk fails.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel

__all__ = ["Walk", "walk"]


@dataclass(frozen=True)
class Walk:
    """A walk: the section states (the start first), each step's length and period, and
    how it ended ('completed' or the failure's name)."""

    names: tuple[str, ...]
    states: list[np.ndarray]
    step_lengths: list[float | None] = field(default_factory=list)
    step_periods: list[float] = field(default_factory=list)
    ended: str = "completed"

    @property
    def steps_completed(self) -> int:
        return len(self.states) - 1

    def to_dict(self) -> dict[str, Any]:
        return {
            "section_states": [dict(zip(self.names, (float(v) for v in x))) for x in self.states],
            "step_lengths": list(self.step_lengths),
            "step_periods": list(self.step_periods),
            "ended": self.ended,
            "steps_completed": self.steps_completed,
        }


def walk(
    model: HybridModel,
    params: Sequence[float],
    start: Sequence[float],
    steps: int,
    progress: Callable[[int, int], None] | None = None,
) -> Walk:
    """``steps`` steps of the Poincaré map from the section state ``start``."""
    x = np.array(start, dtype=float)
    out = Walk((*model.coordinates, *model.rates), [x.copy()])
    ended = model.failure_at(model.step_event["target"], params, x) or "completed"
    for n in range(steps if ended == "completed" else 0):
        result = model.step(params, x)
        if result.ended != "completed":
            ended = result.ended
            break
        x = result.state
        out.states.append(x.copy())
        out.step_lengths.append(result.step_length)
        out.step_periods.append(float(sum(result.durations)))
        if progress is not None:
            progress(n + 1, steps)
    return Walk(out.names, out.states, out.step_lengths, out.step_periods, ended)
