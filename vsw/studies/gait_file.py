"""A powered gait kept in a file and replayed (``vsw optimize --out``, ``--gait FILE``).

The file is the JSON document ``vsw optimize --json`` prints (the envelope every command
starts with, then its keys) holding the gait under the key ``gait``: ``vsw optimize --out
FILE`` writes the envelope and that key, ``vsw optimize --json --verify`` prints a document
that is a gait file too. The record (:func:`gait_record`) holds the model and the gait's
parameter values, the start state, the phases in the step's order with each one's duration
and its inputs at the collocation's knots and midpoints, the events' impulses, the cost and
its statuses, the units and :data:`FORMAT_VERSION`.

A replay (:class:`PoweredReplay`) walks the model with those inputs, open loop, each step
exactly as the verification simulates it (:func:`vsw.synthesis.powered.verify.step_runs`: the inputs
quadratic on each interval as functions of the time since each phase began, each phase
ended by its event's first crossing that counts, the impulses applied there). It stands in
for the model where the simulation, the trajectory export and the animation ask for a walk.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vsw import models
from vsw.dynamics.hybrid import EventRecord, HybridModel, PhasePiece, StepResult, Trajectory
from vsw.dynamics.trajectories import SampledWalk
from vsw.runtime.errors import ConvergenceError, VswInputError
from vsw.synthesis.powered.dynamics import reaction_function
from vsw.synthesis.powered.request import PoweredGait, Request, input_names, ordered_impulses
from vsw.synthesis.powered.step import open_loop_control
from vsw.synthesis.powered.verify import PhaseRun, VerifiedGait, step_runs

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "PoweredReplay",
    "SavedGait",
    "check_parameters",
    "gait_record",
    "load_gait",
    "record_quantities",
    "replay_frames",
    "with_input_forces",
]

FORMAT = "vsw-gait"
FORMAT_VERSION = 1
INTERPOLATION = (
    "each phase's inputs at the collocation's knots and midpoints (input_time: the time "
    "since the phase began); between them the quadratic through knot, midpoint and knot of "
    "each interval, past the phase's last knot the last interval's quadratic continued; "
    "each event's impulses applied at it in the order listed (before its reset, with its "
    "impact, after it)"
)
STATUSES = {
    "optimal": "IPOPT's optimum, judged optimal on both meshes, and verified: the inputs "
    "drive the walker through a periodic step from the start state",
    "verified": "the inputs drive the walker through a periodic step from the start state, "
    "but the collocation did not judge it optimal (collocation.status says why)",
    "unverified": "the verification failed or was not run: the inputs may not repeat the "
    "step (verification says why)",
}


def gait_record(
    model: HybridModel,
    params: Sequence[float],
    request: Request,
    gait: PoweredGait,
    verified: VerifiedGait | str | None,
) -> dict[str, Any]:
    """The gait as the file keeps it (module docstring); ``verified``: the verification
    (:func:`vsw.synthesis.powered.verify.verify`), why it failed, or None when it was not run."""
    names = [*model.coordinates, *model.rates]
    check = _verification(names, verified)
    fixed = isinstance(verified, VerifiedGait)
    start = verified.state if fixed else np.asarray(gait.states[0][0], dtype=float)
    good = check["status"] == "verified"
    status = "unverified" if not good else "optimal" if gait.status == "optimal" else "verified"
    phases = []
    for (phase, event), duration, inputs, times in zip(
        model.phase_sequence(), gait.durations, gait.inputs, gait.input_times
    ):
        phases.append({
            "phase": phase,
            "event": event["name"],
            "duration": float(duration),
            "intervals": (inputs.shape[0] - 1) // 2,
            "input_time": [float(t) for t in times],
            "inputs": {n: inputs[:, j].tolist() for j, n in enumerate(input_names(model)[phase])},
        })  # fmt: skip
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "model": model.cli_name,
        "parameters": dict(zip(model.spec["parameters"], (float(v) for v in params))),
        "status": status,
        "status_meaning": STATUSES[status],
        "minimize": request.minimize,
        "cost": gait.cost,
        "collocation": {
            "status": gait.status,
            "reason": gait.reason or None,
            "ipopt_status": gait.ipopt_status,
            "iterations": gait.iterations,
            "intervals": 2 * request.nodes,
            "period": gait.period,
            "step_length": gait.step_length,
        },
        "verification": check,
        "start": {
            "from": "the open-loop step's fixed point" if fixed else "the collocation's first knot",
            "state": dict(zip(names, (float(v) for v in start))),
        },
        "phases": phases,
        "impulses": {k: float(v) for k, v in gait.impulses.items()},
        "interpolation": INTERPOLATION,
        "units": _record_units(model),
    }


def _verification(names: list[str], verified: VerifiedGait | str | None) -> dict[str, Any]:
    if verified is None:
        return {"status": "not-run", "reason": "vsw optimize ran without --verify or --out"}
    if isinstance(verified, str):
        return {"status": "failed", "reason": verified}
    end = None if verified.end is None else dict(zip(names, verified.end.tolist()))
    return {**verified.summary(), "end_state": end}


def _record_units(model: HybridModel) -> dict[str, Any]:
    inputs = {i["name"]: i["unit"] for p in model.phases for i in p.get("inputs", ())}
    impulses = {f"{e['name']}.{i['name']}": i["unit"]
                for e in model.spec.get("events", ()) for i in e.get("impulses", ())}  # fmt: skip
    return {
        "time": model.units.get("time", ""),
        "length": model.units.get("length", ""),
        "energy": model.units.get("energy", ""),
        "state": {s["name"]: s["unit"] for s in model.spec["state"]},
        "inputs": inputs,
        "impulses": impulses,
        "parameters": {p.name: p.unit for p in model.parameter_table},
    }


def record_quantities(model: HybridModel) -> dict[str, str]:
    """The units of the record's own keys for ``units.quantities``
    (:func:`vsw.cli.output.with_units`)."""
    inputs = {i["name"]: i["unit"] for p in model.phases for i in p.get("inputs", ())}
    return {**inputs, "format_version": "1", "collocation.iterations": "1",
            "collocation.intervals": "1", "intervals": "1",
            "input_time": model.units.get("time", "")}  # fmt: skip


# --- reading ----------------------------------------------------------------------------


@dataclass(frozen=True)
class SavedGait:
    """A gait read from a file: its ``model``, ``params``, ``start`` state, the ``gait``
    as the replay needs it, and the ``record`` as read."""

    model: Any
    params: tuple[float, ...]
    start: np.ndarray
    gait: PoweredGait
    record: dict[str, Any]

    @property
    def status(self) -> str:
        return str(self.record["status"])


def load_gait(path: str, model_key: str | None = None) -> SavedGait:
    """The gait in the file ``path`` (``--gait``), checked against its model as derived;
    ``model_key``: the model the command line names (None: the file's). One-line
    :class:`VswInputError` for a file that is no gait of it."""
    where = f"--gait {path}"
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or exc
        raise VswInputError(f"{where}: cannot read: {reason}") from None
    try:
        document = json.loads(text)
    except json.JSONDecodeError as exc:
        raise VswInputError(f"{where}: not JSON ({exc.msg}, line {exc.lineno})") from None
    record = document.get("gait") if isinstance(document, dict) else None
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        raise VswInputError(f"{where}: not a gait file (no 'gait' object of format {FORMAT}; "
                            "'vsw optimize --out FILE' writes one)")  # fmt: skip
    if record.get("format_version") != FORMAT_VERSION:
        raise VswInputError(f"{where}: gait format version {record.get('format_version')!r}; "
                            f"this vsw reads version {FORMAT_VERSION}")  # fmt: skip
    name = _field(record, "model", str, where)
    try:
        key = models.key(name)
    except VswInputError:
        raise VswInputError(f"{where}: its model {name!r} is not one vsw knows") from None
    if model_key is not None and model_key != key:
        given = models.cli_name(model_key)
        raise VswInputError(f"{where} is a gait of {name}, not of {given}: drop --model or give "
                            f"--model {name}")  # fmt: skip
    model = models.load(key)
    return _saved(model, record, where)


def _field(mapping: Any, key: str, kind: type, where: str, label: str = "") -> Any:
    """``mapping[key]`` of type ``kind``, else one line naming what is missing."""
    value = mapping.get(key) if isinstance(mapping, dict) else None
    if kind is float and isinstance(value, (int, float)) and not isinstance(value, bool):
        if math.isfinite(value):
            return float(value)
    elif isinstance(value, kind) and not isinstance(value, bool):
        return value
    raise VswInputError(f"{where}: not a gait file: {label or 'gait.'}{key} is missing or not "
                        f"a{'n' if kind is int else ''} {_KIND[kind]}")  # fmt: skip


_KIND = {float: "finite number", str: "string", dict: "object", list: "list", int: "integer"}


def _numbers(mapping: Any, names: Sequence[str], where: str, label: str) -> list[float]:
    """The finite numbers of ``mapping`` under ``names``, exactly those keys."""
    if not isinstance(mapping, dict) or set(mapping) != set(names):
        raise VswInputError(f"{where}: not a gait of this model: {label} must name "
                            f"{', '.join(names) or 'nothing'}")  # fmt: skip
    return [_field(mapping, n, float, where, f"{label}.") for n in names]


def _saved(model: Any, record: dict, where: str) -> SavedGait:
    """The record checked against ``model`` and turned into what the replay needs."""
    params = _numbers(record.get("parameters"), model.spec["parameters"], where, "parameters")
    model.parameters(dict(zip(model.spec["parameters"], params)))  # within the table's bounds
    names = [*model.coordinates, *model.rates]
    start = _numbers(_field(record, "start", dict, where).get("state"), names, where,
                     "start.state")  # fmt: skip
    if _field(record, "status", str, where) not in STATUSES:
        raise VswInputError(f"{where}: not a gait file: its status must be one of "
                            f"{', '.join(STATUSES)}")  # fmt: skip
    phases = _field(record, "phases", list, where)
    sequence = model.phase_sequence()
    if [p.get("phase") if isinstance(p, dict) else None for p in phases] != [
        phase for phase, _ in sequence
    ]:
        raise VswInputError(f"{where}: not a gait of this model: its phases are not "
                            f"{', '.join(p for p, _ in sequence)}")  # fmt: skip
    durations, inputs = [], []
    for record_phase, (phase, _event) in zip(phases, sequence):
        duration = _field(record_phase, "duration", float, where, f"phases.{phase}.")
        intervals = _field(record_phase, "intervals", int, where, f"phases.{phase}.")
        if not (duration > 0 and intervals >= 1):
            raise VswInputError(f"{where}: phase {phase}'s duration and intervals must be "
                                "positive")  # fmt: skip
        named = input_names(model)[phase]
        values = record_phase.get("inputs")
        if not isinstance(values, dict) or set(values) != set(named):
            raise VswInputError(f"{where}: not a gait of this model: phase {phase}'s inputs "
                                f"must be {', '.join(named) or 'none'}")  # fmt: skip
        columns = [_samples(values[n], 2 * intervals + 1, where, f"{phase}.{n}") for n in named]
        inputs.append(np.array(columns, dtype=float).T.reshape(2 * intervals + 1, len(named)))
        durations.append(duration)
    wanted = [f"{e['name']}.{n}" for _, e in sequence for n in ordered_impulses(model, e)]
    impulses = _numbers(record.get("impulses"), wanted, where, "impulses")
    gait = _replay_gait(model, params, start, durations, inputs, dict(zip(wanted, impulses)))
    return SavedGait(model, tuple(params), np.array(start), gait, record)


def _samples(values: Any, count: int, where: str, label: str) -> list[float]:
    if not isinstance(values, list) or len(values) != count:
        raise VswInputError(f"{where}: input {label} must have {count} values (its knots and "
                            "midpoints)")  # fmt: skip
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
               for v in values):  # fmt: skip
        raise VswInputError(f"{where}: input {label} must be finite numbers")
    return [float(v) for v in values]


def _replay_gait(model: Any, params: list[float], start: list[float], durations: list[float],
                 inputs: list[np.ndarray], impulses: dict[str, float]) -> PoweredGait:  # fmt: skip
    """A :class:`PoweredGait` holding what a step with the inputs needs (durations, inputs,
    impulses, parameters); the collocation's other fields empty."""
    times = [np.linspace(0.0, d, (u.shape[0] + 1) // 2) for d, u in zip(durations, inputs)]
    return PoweredGait(
        status="saved", reason="", cost=math.nan, durations=tuple(durations), times=times,
        states=[np.array([start])], inputs=inputs,
        input_times=[np.linspace(0.0, d, u.shape[0]) for d, u in zip(durations, inputs)],
        work={}, step_length=None, speed=None, resimulation_error=math.nan,
        guard_at_end=math.nan, ipopt_status="", iterations=0, impulses=impulses,
        parameters=tuple(params),
    )  # fmt: skip


def check_parameters(saved: SavedGait, values: Mapping[str, float]) -> None:
    """Parameters the command line gives with ``--gait``: each must be the gait's (one
    line naming the first that is not)."""
    recorded = dict(zip(saved.model.spec["parameters"], saved.params))
    for name, value in values.items():
        if not value == recorded[name]:
            raise VswInputError(f"--param {name}={value:g} contradicts the gait's {name} = "
                                f"{recorded[name]!r}: a gait is replayed at its own parameters "
                                "(drop --param)")  # fmt: skip


# --- replaying ----------------------------------------------------------------------------


@dataclass(frozen=True)
class _Run:
    """A phase of a replayed walk: the step it falls in, its start on the walk's clock,
    its end, and whether it reached its event (else a failure ended the walk there)."""

    step: int
    start: float
    end: float
    run: PhaseRun
    complete: bool = True


class PoweredReplay:
    """``model`` walked with a saved gait's inputs (module docstring): its ``step``,
    ``simulate`` and ``continuous_walk`` replay them; every other attribute is the
    model's. A failure (with the inputs' share in its guard) ends the walk where it is
    crossed; a phase that meets no event ends it 'stalled'."""

    def __init__(self, model: Any, gait: PoweredGait) -> None:
        self._model = model
        self._gait = gait
        self._p = np.array(gait.parameters, dtype=float)
        self.last_runs: list[_Run] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._model, name)

    def failure_at(self, phase: str, params: Sequence[float], state: np.ndarray) -> str | None:
        return None  # failures are watched along the phases, with the inputs

    def _walk(self, state: np.ndarray, steps: int) -> tuple[list[_Run], str]:
        """The phases of ``steps`` steps from ``state`` and how the walk ended."""
        runs: list[_Run] = []
        x, t = np.array(state, dtype=float), 0.0
        for k in range(steps):
            try:
                step = step_runs(self._model, self._p, self._gait, x)
            except ConvergenceError:
                self.last_runs = runs
                return runs, "stalled"
            for run in step:
                if run.failure is not None:
                    runs.append(_Run(k, t, t + run.failure[1], run, complete=False))
                    self.last_runs = runs
                    return runs, run.failure[0]
                runs.append(_Run(k, t, t + run.end_time, run))
                t += run.end_time
            x = step[-1].after
        self.last_runs = runs
        return runs, "completed"

    def step(self, params: Sequence[float], state: np.ndarray) -> StepResult:
        runs, ended = self._walk(state, 1)
        durations = tuple(r.end - r.start for r in runs)
        if ended != "completed":
            return StepResult(np.array(state, dtype=float), ended, durations)
        return StepResult(runs[-1].run.after.copy(), ended, durations, self._length(runs[-1]))

    def _length(self, run: _Run) -> float | None:
        return self._model.step_length(self._p, run.run.before)

    def simulate(self, params: Sequence[float], state: np.ndarray, steps: int,
                 phase: str | None = None, max_step: float = np.inf) -> Trajectory:  # fmt: skip
        """As :meth:`vsw.dynamics.hybrid.HybridModel.simulate`: samples at most ``max_step`` apart
        (and at least 40 a phase) from the dense output, the state before each event at
        its instant and the state after it at the same instant (not after the last)."""
        runs, ended = self._walk(state, steps)
        ts, xs, ps, section = [], [], [], [np.array(state, dtype=float)]
        for r in runs:
            length = r.run.end_time if r.complete else r.end - r.start
            count = max(40, math.ceil(length / max_step) if math.isfinite(max_step) else 0) + 1
            local = np.linspace(0.0, length, count)
            states = np.asarray(r.run.solution.sol(local), dtype=float).T
            if r.complete:
                states[-1] = r.run.before
            ts.extend(r.start + local)
            xs.extend(states)
            ps.extend([self._model.phase_index[r.run.phase]] * count)
            if r.run.event["ends_step"] and r.complete:
                section.append(r.run.after.copy())
        done = len(section) - 1
        return Trajectory(np.array(ts), np.array(xs), np.array(ps), np.array(section), ended,
                          done)  # fmt: skip

    def continuous_walk(
        self, params: Sequence[float], state: np.ndarray, steps: int
    ) -> tuple[list[PhasePiece], list[tuple[int, EventRecord]], str]:
        """As :meth:`vsw.dynamics.hybrid.HybridModel.continuous_walk`, replayed."""
        runs, ended = self._walk(state, steps)
        pieces, events = [], []
        fn = self._model.function
        for r in runs:
            solution = _Shifted(r.run.solution.sol, r.start)
            pieces.append(PhasePiece(r.run.phase, r.step, r.start, r.end,
                                     ((solution, r.start, r.end),)))  # fmt: skip
            if not r.complete:
                break
            event = r.run.event
            before, after = r.run.before, r.run.after
            events.append((r.step, EventRecord(
                event["name"], r.end, before.copy(), after.copy(),
                float(fn(f"{r.run.phase}_energy")(*self._p, *before)),
                float(fn(f"{event['target']}_energy")(*self._p, *after)),
            )))  # fmt: skip
        return pieces, events, ended


class _Shifted:
    """A phase's dense output on the walk's clock (the phase began at ``start``)."""

    def __init__(self, solution: Any, start: float) -> None:
        self.solution, self.start = solution, start

    def __call__(self, t: Any) -> np.ndarray:
        return self.solution(np.asarray(t, dtype=float) - self.start)


def replay_frames(saved: SavedGait, per_step: int = 400) -> dict[str, Any]:
    """One replayed step for the explorer's page: ``frames`` [t, phase, state] about
    ``per_step`` a step (and each event's states on either side), its period, step
    length, start and end states, status."""
    replay = PoweredReplay(saved.model, saved.gait)
    period = saved.gait.period
    trajectory = replay.simulate(saved.params, saved.start, 1, max_step=period / per_step)
    if trajectory.ended != "completed":
        raise ConvergenceError(f"{saved.model.cli_name}: the saved gait's step ends with "
                               f"{trajectory.ended}")  # fmt: skip
    names = [p["name"] for p in saved.model.phases]
    frames = [[float(t), names[k], [float(v) for v in x]]
              for t, k, x in zip(trajectory.t, trajectory.phase, trajectory.states)]  # fmt: skip
    return {
        "frames": frames,
        "period": float(trajectory.t[-1]),
        "length": saved.model.step_length(saved.params, trajectory.states[-1]),
        "end_state": [float(v) for v in trajectory.section[-1]],
        "status": saved.status,
    }


def with_input_forces(replay: PoweredReplay, walk: SampledWalk) -> SampledWalk:
    """``walk`` (sampled from ``replay``'s last walk) with the stance's normal force of each
    row with the inputs' share (the generated ``<phase>_normal_force`` is the passive
    walker's): the normal part of the ground's reaction at the row's state and input."""
    if walk.normal_force is None:
        return walk
    model, p = replay._model, replay._p
    starts = {(r.step, r.run.phase): r.start for r in replay.last_runs}
    gait = replay._gait
    sequence = zip(model.phase_sequence(), gait.durations, gait.inputs)
    controls = {phase: open_loop_control(u, duration) for (phase, _), duration, u in sequence}
    force = walk.normal_force.copy()
    for i, (t, step, phase, event) in enumerate(zip(walk.t, walk.step, walk.phase, walk.event)):
        if not input_names(model)[phase]:
            continue
        since = 0.0 if event.endswith(":after") else t - starts.get((int(step), phase), t)
        reaction = reaction_function(model, phase)(p, walk.states[i], controls[phase](since))
        force[i] = float(np.array(reaction, dtype=float).reshape(-1)[1])
    return dataclasses.replace(walk, normal_force=force)
