"""A design request checked against a model (:class:`Problem`): its names, the free
parameters and their boxes, the start, the objective and the NLP's structure; the least
margin imposed on each failure."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from vsw.dynamics.hybrid import HybridModel
from vsw.dynamics.quantities import objective_names
from vsw.runtime.errors import VswInputError
from vsw.synthesis.design.nlp import Structure
from vsw.synthesis.design.request import (
    CLOSED_FAILURES,
    CLOSED_MARGIN,
    DESIGN_QUANTITIES,
    STRICT_MARGIN,
    DesignRequest,
    open_distance,
    range_text,
)

__all__ = ["Problem", "margin_floor"]


class Problem:
    """A request checked against a model: free parameters, their boxes, the structure."""

    def __init__(self, model: HybridModel, request: DesignRequest) -> None:
        self.model = model
        self.request = request
        self.table = list(model.parameter_table)
        names = [p.name for p in self.table]
        self.available = set(DESIGN_QUANTITIES) - (
            set() if model.spec["step_length"] else {"speed", "step_length"}
        )
        self._check_names(names)
        self.free = tuple(j for j, p in enumerate(self.table) if self._is_free(p))
        self.box = {j: self._box(self.table[j]) for j in self.free}
        self.start = self._start_parameters()
        self.objective = self._objective()
        self.rows = tuple(sorted(set(request.targets) | (set(request.bounds) & self.available)))
        self.eigen = ("objective" if "eigenvalue" in self.objective
                      else "bound" if request.max_eigenvalue is not None else None)  # fmt: skip
        if len(request.targets) > len(self.free):
            raise VswInputError(
                f"{len(request.targets)} target(s) ({', '.join(request.targets)}) for "
                f"{len(self.free)} free parameter(s) ({self.free_names() or 'none'}): each "
                "target needs a parameter to meet it; free one (drop a --fix, or --bound a "
                "scale)"
            )

    def free_names(self) -> str:
        return ", ".join(self.table[j].name for j in self.free)

    def _check_names(self, names: list[str]) -> None:
        request = self.request
        for name in request.fixed:
            if name not in names:
                raise VswInputError(f"--fix {name}: not a parameter of {self.model.name} "
                                    f"(its parameters: {', '.join(names)})")  # fmt: skip
        for name in request.bounds:
            if name not in names and name not in self.available:
                raise VswInputError(
                    f"--bound {name}: neither a parameter of {self.model.name} "
                    f"({', '.join(names)}) nor a quantity ({', '.join(sorted(self.available))})"
                )
        for name in request.targets:
            if name not in self.available:
                raise VswInputError(f"target {name}: {self.model.name} has no such quantity "
                                    f"(it has {', '.join(sorted(self.available))})")  # fmt: skip
        for name, value in request.targets.items():
            low, high = request.bounds.get(name, (None, None))
            if (low is not None and value < low) or (high is not None and value > high):
                raise VswInputError(f"target {name} = {value:g} contradicts --bound "
                                    f"{name}={range_text(low, high)}")  # fmt: skip
        objectives = [n.replace("-", "_") for n in objective_names("design")]
        for term in request.objective:
            if term not in objectives:
                raise VswInputError(f"objective {term!r}: choose from "
                                    f"{', '.join(objectives)}")  # fmt: skip
            if (
                term in ("speed", "step_length", "cost_of_transport")
                and "speed" not in self.available
            ):
                raise VswInputError(f"objective {term}: {self.model.name} defines no step length")
        for name in request.start:
            if name not in names:
                raise VswInputError(f"--start {name}: not a parameter of {self.model.name} "
                                    f"(its parameters: {', '.join(names)})")  # fmt: skip
            if name in request.fixed:
                raise VswInputError(f"--start {name} and --fix {name}: a fixed parameter has "
                                    "no start; give one")  # fmt: skip
        e = request.max_eigenvalue
        if e is not None and not (math.isfinite(e) and e > 0):
            raise VswInputError(f"--max-eigenvalue {e}: must be a positive number")

    def _is_free(self, p: Any) -> bool:
        if p.name in self.request.fixed:
            value = self.request.fixed[p.name]
            if p.name in self.request.bounds:
                low, high = self.request.bounds[p.name]
                if (low is not None and value < low) or (high is not None and value > high):
                    raise VswInputError(f"--fix {p.name}={value:g} contradicts --bound "
                                        f"{p.name}={range_text(low, high)}")  # fmt: skip
            _inside_table(p, value, f"--fix {p.name}={value:g}")
            return False
        # A parameter on (0, inf) is held unless bounded: the tables do not say which are
        # pure scales (g, an overall mass or length: the gait's units only) and which
        # ratios (a leg's mass against the hip's), and with no finite interval there is no
        # box to design in. The user's --bound makes it a design variable.
        scale = p.lower == 0 and math.isinf(p.upper)
        return not scale or p.name in self.request.bounds

    def _box(self, p: Any) -> tuple[float, float]:
        distance = open_distance(p)
        low, high = p.lower + distance, p.upper - distance
        if p.computed is not None:
            low, high = max(low, p.computed[0]), min(high, p.computed[1])
        user_low, user_high = self.request.bounds.get(p.name, (None, None))
        for value in (user_low, user_high):
            if value is not None:
                _inside_table(p, value, f"--bound {p.name}={range_text(user_low, user_high)}")
        if user_low is not None:
            low = max(low, user_low)
        if user_high is not None:
            high = min(high, user_high)
        if not low <= high:
            raise VswInputError(f"--bound {p.name}={range_text(user_low, user_high)}: empty")
        if math.isinf(low) or math.isinf(high):
            raise VswInputError(f"--bound {p.name}: give a finite interval (A:B)")
        return low, high

    def _start_parameters(self) -> tuple[float, ...]:
        free_names = {self.table[j].name for j in self.free}
        for name in self.request.start:
            if name not in free_names:
                raise VswInputError(f"--start {name}: not designed (a scale on (0, inf) is "
                                    "held unless --bound gives it an interval)")  # fmt: skip
        out = []
        for j, p in enumerate(self.table):
            value = self.request.fixed.get(p.name, p.default)
            if j in self.box:
                low, high = self.box[j]
                if p.name in self.request.start:
                    value = self.request.start[p.name]
                    if not low <= value <= high:
                        raise VswInputError(f"--start {p.name}={value:g}: outside its design "
                                            f"interval [{low:g}, {high:g}]")  # fmt: skip
                elif not low <= value <= high:
                    value = 0.5 * (low + high)
            out.append(float(value))
        return tuple(out)

    def _objective(self) -> dict[str, float]:
        objective = dict(self.request.objective)
        if not objective:
            if not self.request.targets and self.request.max_eigenvalue is None:
                raise VswInputError("give an objective (--maximize/--minimize) or a target")
            objective = {"eigenvalue": 1.0}
        return objective

    def structure(
        self,
        rank: int,
        objective: Mapping[str, float] | None = None,
        rows: tuple[str, ...] | None = None,
        eigen: str | None = "same",
    ) -> Structure:
        objective = self.objective if objective is None else objective
        eigen = self.eigen if eigen == "same" else eigen
        return Structure(
            self.free,
            tuple(sorted(objective.items())),
            self.rows if rows is None else rows,
            eigen,
            rank if eigen else 0,
        )


def _inside_table(p: Any, value: float, given: str) -> None:
    if not (math.isfinite(value) and p.lower < value < p.upper):
        raise VswInputError(f"{given}: {p.name} must lie in the open interval "
                            f"({p.lower:.6g}, {p.upper:.6g}): {p.reason}")  # fmt: skip
    if p.computed is not None and not p.computed[0] <= value <= p.computed[1]:
        raise VswInputError(
            f"{given}: {p.name} outside the computed range "
            f"[{p.computed[0]:.6g}, {p.computed[1]:.6g}]: {p.computed_reason}"
        )


def margin_floor(failure: str, request: DesignRequest) -> float:
    """The least margin the NLP imposes on a failure's guard."""
    floor = CLOSED_MARGIN if failure in CLOSED_FAILURES else STRICT_MARGIN
    return max(floor, request.min_margin)
