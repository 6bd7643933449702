"""The model interface every command uses: the generic runtime plus what a command asks.

:class:`Model` is :class:`vsw.dynamics.hybrid.HybridModel` (simulation, the Poincaré map, periodic
orbits, eigenvalues: driven by the generated package alone) with the answers the commands
need in one place: the model's description (:meth:`Model.describe`: parameters, state with
each coordinate's meaning, reference and sign, section, units), its gaits at a parameter
set with every condition's margin or the reason there is none (:meth:`Model.analyze`,
:mod:`vsw.gaits.search`, :mod:`vsw.dynamics.conditions`) and where a walk starts
(:meth:`Model.start`). A model with closed forms of its own (the ILE) subclasses it and answers the
same calls
from them; :attr:`Model.features` says which optional commands and options a model has.
"""

from __future__ import annotations

import importlib
import math
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np

from vsw.dynamics import conditions
from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.dynamics.ledger import energy_ledger
from vsw.dynamics.trajectories import sample_walk
from vsw.gaits import search as gaits
from vsw.plots.explore_page import check_html_path, write_page
from vsw.plots.figures import save_figure
from vsw.plots.walk_plot import walk_figure
from vsw.runtime import stop
from vsw.runtime.errors import ConvergenceError, ModelConditionError, VswInputError

__all__ = ["FEATURES", "SEARCHES_KEPT", "GaitReport", "Model", "Start"]

SEARCHES_KEPT = 32
"""Gait searches kept per model and process (:meth:`Model.search_gaits`)."""

FEATURES = {
    "q0": "--q0: the section state from q = rate**2 (a model whose section has one free "
    "component, its rate)",
    "scale": "--leg-length/--mass/--stepper-2d: SI results",
    "parameter-basin": "vsw basin over theta_II and q0 in closed form (Fig. 9)",
    "closed-form-sweep": "vsw sweep in closed form",
    "simulation-plot": "vsw simulate --plot",
    "design": "vsw design (the ILE from its closed forms, every other model on its periodic orbit)",
    "explorer": "vsw explore",
    "optimize": "vsw optimize (a model with inputs: its powered gaits)",
}
"""Optional features of a model (:attr:`Model.features`) and what each is."""

PLOT_RATE = 400.0
"""Samples per model time unit of ``vsw simulate --plot`` (with each event's instant)."""


@dataclass
class GaitReport:
    """What ``vsw analyze`` says of a model at a parameter set.

    ``gaits``: each with its conditions' margins (``conditions``, in the same order);
    ``closed_form``: the closed-form fixed point and conditions where the model has them;
    ``search``: how the gaits were searched (None where the closed form answers alone);
    ``reason``: one sentence when there is no gait; ``extra``: a model's own keys (the
    ILE's closed-form analysis); ``rows``: its own text table, (name, value, unit);
    ``ledgers``: each gait's energy ledger over a step (:mod:`vsw.dynamics.ledger`).
    """

    gaits: list[Orbit]
    conditions: list[list[dict[str, Any]]]
    search: gaits.GaitSearch | None = None
    closed_form: dict[str, Any] | None = None
    reason: str | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    rows: list[tuple[str, Any, str]] = field(default_factory=list)
    ledgers: list[dict[str, Any] | None] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = dict(self.extra)
        out["fixed_points"] = [
            {**orbit.to_dict(), "conditions": margins}
            for orbit, margins in zip(self.gaits, self.conditions)
        ]
        for point, ledger in zip(out["fixed_points"], self.ledgers):
            point["energy_ledger"] = ledger
        if self.closed_form is not None:
            out["closed_form"] = self.closed_form
        if self.search is not None:
            out["search"] = self.search.method()
        out["reason"] = self.reason
        return out


@dataclass(frozen=True)
class Start:
    """Where a walk starts: the section state, what gave it (``--state``, ``--q0`` or
    ``gait``) and the gait when it is one (its stability is worth saying)."""

    state: np.ndarray
    source: str
    gait: Orbit | None = None
    q0: float | None = None

    def note(self) -> str | None:
        """A warning when the walk starts on an unstable gait."""
        if self.gait is None or self.gait.stable:
            return None
        return (f"the walk starts on an unstable gait (max |eigenvalue| "
                f"{self.gait.max_abs_eigenvalue:.4g}): rounding grows along it")  # fmt: skip


class Model(HybridModel):
    """A generated model through the one interface of the commands."""

    features: frozenset[str] = frozenset({"simulation-plot", "explorer", "design"})

    routes: ClassVar[Mapping[str, str]] = MappingProxyType({})
    """Commands a model answers by a route of its own (its closed forms), by command: the
    module path of that route, whose ``run(args, model)`` the command calls in place of its
    generic one (:meth:`route`). Imported when the command runs on this model, so a command
    on another model imports none of it."""

    def __init__(self, module: Any) -> None:
        super().__init__(module)
        self._searches: dict[tuple, gaits.GaitSearch] = {}
        self._searches_lock = threading.Lock()
        free = list(self.spec["search"])
        if len(free) == 1 and free[0] in self.rates:
            self.features = self.features | {"q0"}
        if any(p.get("inputs") for p in self.phases) or any(e.get("impulses") for e in self.events):
            self.features = self.features | {"optimize"}
        if self.spec.get("powered_only"):  # no passive gait to design or explore
            self.features = self.features - {"design", "explorer"}

    # --- description --------------------------------------------------------------------

    @property
    def cli_name(self) -> str:
        return self.name.replace("_", "-")

    def describe(self) -> dict[str, Any]:
        """The model as ``vsw models --json`` lists it: parameters, state, section, units."""
        units = dict(self.units)
        time = units.get("time", "")
        # Rates are in their coordinate's unit per time: one unit when the coordinates
        # share it (angles: rad), else each rate's own (the state lists them).
        kinds = {s["unit"] for s in self.spec["state"] if s["kind"] == "coordinate"}
        if len(kinds) == 1:
            unit = kinds.pop()
            units["rate"] = f"{unit}/{time}" if time else unit
        else:
            units["rate"] = None
        return {
            "name": self.cli_name,
            "title": self.title,
            "description": self.spec.get("description", self.title),
            "units": units,
            "parameters": [
                {
                    "name": p.name,
                    "default": p.default,
                    "unit": p.unit,
                    "lower": _bound(p.lower),
                    "upper": _bound(p.upper),
                    "meaning": p.description,
                    "reason": p.reason,
                    "computed": [_bound(v) for v in p.computed or (p.lower, p.upper)],
                    "computed_reason": p.computed_reason,
                    "degrees_accepted": p.unit == "rad",
                }
                for p in self.parameter_table
            ],
            "state": [dict(s) for s in self.spec["state"]],
            "section": {
                "event": self.step_event["name"],
                "when": f"just after the {self.step_event['name']} (the state a step starts from)",
                "determined": list(self.spec["section"]),
                "free": list(self.spec["search"]),
                "search_box": {k: list(v) for k, v in self.spec["search"].items()},
            },
            "failures": [dict(f) for f in self.spec["failures"]],
            "conditions": [dict(c) for c in self.spec.get("conditions", ())],
            # Actuators that hold a moving coordinate, by phase (their work is in the
            # energy ledger of `vsw analyze`); events whose reset is an actuator's jump;
            # the model's names of its actuators (coordinate -> name) and the coordinates
            # whose actuators act at each jump or lock.
            "actuators": {
                p["name"]: list(p["actuators"]) for p in self.phases if p.get("actuators")
            },
            "jumps": [e["name"] for e in self.events if e["reset"] == "jump"],
            "actuator_names": dict(self.spec.get("actuator_names", {})),
            "actuated": {e["name"]: list(e["actuated"]) for e in self.events if "actuated" in e},
            # Continuous inputs by phase (zero in every passive command): the powered-walking
            # issue's controls, each with its actuator, what it acts along and its bounds.
            "inputs": {
                p["name"]: [dict(i) for i in p["inputs"]] for p in self.phases if p.get("inputs")
            },
            # Impulsive inputs by event, each applied before the event's reset, with its
            # impact (along a held coordinate) or after it.
            "impulses": {
                e["name"]: [dict(i) for i in e["impulses"]]
                for e in self.events
                if e.get("impulses")
            },
            "features": sorted(self.features),
        }

    # --- gaits ----------------------------------------------------------------------------

    def search_gaits(
        self,
        params: Sequence[float],
        box: Mapping[str, tuple[float, float]] | None = None,
        cells: int | None = None,
    ) -> gaits.GaitSearch:
        """The period-one gaits at ``params`` and how they were searched (:mod:`vsw.gaits.search`).

        The last :data:`SEARCHES_KEPT` searches are kept per model and process: a search
        takes seconds on a model with three free section components, and commands and
        scripts ask for the same parameters again (a sweep's scans, a basin after
        ``analyze``). ``cells``: the scan's size (default :mod:`vsw.gaits.search`' own)."""
        key = (tuple(float(v) for v in params), tuple(sorted((box or {}).items())), cells)
        with self._searches_lock:
            if key in self._searches:
                self._searches[key] = self._searches.pop(key)  # most recent last
                return self._searches[key]
        found = gaits.search(self, params, box=box, cells=cells)
        stop.check()  # a stopped search is not kept, whatever a library made of the stop
        with self._searches_lock:
            self._searches[key] = found
            while len(self._searches) > SEARCHES_KEPT:
                self._searches.pop(next(iter(self._searches)))
        return found

    def stable_gait(self, params: Sequence[float], purpose: str) -> Orbit:
        """The first stable gait (by period) at ``params``, or ModelConditionError saying
        what was found and what it was wanted for (``purpose``)."""
        found = self.search_gaits(params)
        stable = [o for o in found.gaits if o.stable]
        if stable:
            return stable[0]
        if found.gaits:
            least = min(o.max_abs_eigenvalue for o in found.gaits)
            raise ModelConditionError(
                f"{self.name}: no stable period-one gait at these parameters "
                f"({len(found.gaits)} unstable, the least with max |eigenvalue| {least:.4g}): "
                f"{purpose}"
            )
        raise ModelConditionError(f"{self.name}: {found.why_none()}: {purpose}")

    def fixed_points(self, params: Sequence[float]) -> list[Orbit]:
        """The period-one gaits at ``params`` (sorted by period)."""
        return self.search_gaits(params).gaits

    def analyze(
        self, params: Sequence[float], box: Mapping[str, tuple[float, float]] | None = None
    ) -> GaitReport:
        """Every gait in the search box with its conditions' margins, the closed form where
        the model has one, and the reason when there is no gait."""
        found = self.search_gaits(params, box)
        closed = conditions.closed_form_conditions(self, params)
        report = GaitReport(
            gaits=found.gaits,
            conditions=[conditions.gait_conditions(self, params, g) for g in found.gaits],
            search=found,
            closed_form=closed,
            ledgers=[self._ledger(params, g) for g in found.gaits],
        )
        if not found.gaits:
            report.reason = (
                _closed_form_reason(closed) or self._stride_map_reason(params) or found.why_none()
            )
            if self.spec.get("powered_only"):
                report.reason = (f"{self.cli_name} walks only powered: its inputs hold it up "
                                 f"('vsw optimize' finds its gaits); {report.reason}")  # fmt: skip
        return report

    def _ledger(self, params: Sequence[float], orbit: Orbit) -> dict[str, Any] | None:
        """The gait's energy ledger, or None where its step could not be re-simulated
        (the report of the other gaits stands)."""
        try:
            return energy_ledger(self, params, orbit)
        except ConvergenceError:
            return None

    def _stride_map_reason(self, params: Sequence[float]) -> str | None:
        """Why the closed-form fixed point of the stride map (q = rate**2 just after the
        step event) is no gait, for a model that has one but no closed-form conditions: a
        step from it fails, or it has no real rate."""
        if not hasattr(self.module, "q_fixed") or "q0" not in self.features:
            return None
        with np.errstate(all="ignore"):
            q_f = float(self.module.q_fixed(*params))
        if not (q_f > 0 and math.isfinite(q_f)):
            return (f"the closed-form fixed point q^f = {q_f:.6g} of the stride map is not a "
                    "positive finite rate squared")  # fmt: skip
        step = self.step(params, self.section_state_from_q(params, q_f))
        if step.ended == "completed":
            return None
        return (f"the closed-form fixed point q^f = {q_f:.6g} of the stride map is no gait: a "
                f"step from it ends with {step.ended}")  # fmt: skip

    # --- walks ----------------------------------------------------------------------------

    def section_state_from_q(self, params: Sequence[float], q0: float) -> np.ndarray:
        """The section state with rate**2 = ``q0`` at the model's section angle."""
        if "q0" not in self.features:
            raise VswInputError(f"--q0 needs a model with a closed-form section ({self.cli_name} "
                                "has none): give --state NAME=VALUE")  # fmt: skip
        if not (math.isfinite(q0) and q0 > 0):
            raise VswInputError(f"--q0 = {q0:g} must be a positive number (q = rate**2 just "
                                "after the step event)")  # fmt: skip
        return gaits.section_states(self, params, np.array([[math.sqrt(q0)]]))[0]

    def start(
        self,
        params: Sequence[float],
        state: Sequence[float] | None = None,
        q0: float | None = None,
    ) -> Start:
        """Where a walk starts: ``state``, else the state of ``q0``, else the first stable
        gait (else the first gait); ModelConditionError with the reason when none is found."""
        if state is not None:
            return Start(np.asarray(state, dtype=float), "--state")
        if q0 is not None:
            return Start(self.section_state_from_q(params, q0), "--q0", q0=q0)
        report = self.analyze(params)
        orbit = gaits.pick(report.gaits)
        if orbit is None:
            raise ModelConditionError(
                f"{self.cli_name}: {report.reason}; give the start with --state NAME=VALUE"
            )
        return Start(np.array(list(orbit.state.values())), "gait", orbit)

    def walk_keys(self, params: Sequence[float], walk: Any, start: Start) -> dict[str, Any]:
        """A walk's keys beyond the section states: with a one-rate section, ``q`` (the
        rate squared after each step, the start's first: ``--q0`` as given) and the
        closed-form fixed point where the model has one."""
        out: dict[str, Any] = {}
        if "q0" in self.features:
            rate = self.rates[0]
            index = [*self.coordinates, *self.rates].index(rate)
            out["q"] = [float(x[index]) ** 2 for x in walk.states]
            if start.q0 is not None:
                out["q"][0] = float(start.q0)
            if hasattr(self.module, "q_fixed"):
                with np.errstate(all="ignore"):
                    out["q_fixed_closed_form"] = float(self.module.q_fixed(*params))
        return out

    def save_simulation_plot(
        self, params: Sequence[float], start: np.ndarray, steps: int, path: str
    ) -> None:
        """The walk over time (:func:`vsw.plots.walk_plot.walk_figure`): its coordinates, rates
        and energy sampled at :data:`PLOT_RATE` per time unit, every event marked."""
        walk = sample_walk(self, params, start, steps, PLOT_RATE)
        save_figure(walk_figure(self, params, walk), path)

    def route(self, command: str) -> Callable[..., int] | None:
        """The ``run(args, model)`` of the model's own route for ``command`` (:attr:`routes`),
        or None where the command's generic route serves it."""
        path = self.routes.get(command)
        return None if path is None else importlib.import_module(path).run

    def robot_scale(
        self, leg_length: float | None, mass: float | None, gravity: float | None, preset: bool
    ) -> Any:
        """The robot scale of SI results (the ``scale`` feature: ``--leg-length``, ``--mass``,
        ``--gravity``, ``--stepper-2d``), None where none is given; a model without the
        feature has none."""
        if any(v is not None for v in (leg_length, mass, gravity)) or preset:
            raise VswInputError(f"{self.cli_name}: no SI results (--leg-length, --mass, "
                                "--gravity, --stepper-2d): its values are in its own "
                                "units")  # fmt: skip
        return None

    def write_explorer(self, path: str, params: Sequence[float], **options: Any) -> Path:
        """``vsw explore``: the self-contained page (:mod:`vsw.plots.explore_page`); the sliders
        start at ``params``, Newton's first guess is the model's gait there (the stable one
        where there is one). ``options``: the ILE's (its leg length); none here."""
        check_html_path(path)  # before the gait search
        return write_page(path, self, params, self.start(params, None, None).state)


def _bound(value: float) -> float | None:
    """A table bound for JSON: None where it is infinite (no bound)."""
    return float(value) if math.isfinite(value) else None


def _closed_form_reason(closed: dict[str, Any] | None) -> str | None:
    """Why the closed-form fixed point is no gait, or None (no closed form, or it walks)."""
    if closed is None:
        return None
    q_f = closed["q_fixed"]
    bad = conditions.failing(closed)
    if not bad:
        return None
    worst = bad[0]
    unit = f" {worst['unit']}" if worst["unit"] else ""
    others = "" if len(bad) == 1 else f" (and {', '.join(c['name'] for c in bad[1:])})"
    return (f"the closed-form fixed point q^f = {q_f:.6g} is no gait: condition {worst['name']} "
            f"fails, margin {worst['margin']:.6g}{unit} ({worst['meaning']}){others}")  # fmt: skip
