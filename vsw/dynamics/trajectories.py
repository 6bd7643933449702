"""Trajectories out: a simulated walk sampled at a fixed rate, with its energy, contact
force and events, written as CSV, NumPy ``.npz`` or MATLAB ``.mat`` (``vsw simulate
--trajectory FILE --rate R``).

The samples are at the times k / rate (k = 0, 1, ...) of the walk's clock, read from the
integrator's own dense output (DOP853's 7th-order interpolant, SciPy), not interpolated
between stored points; each event adds two rows at its instant, the state just before and
just after its reset, so impacts and leg extensions are exact in the file. Per sample: the
time, the step (0 = the first), the phase, the state (coordinates, then rates), the
mechanical energy of the phase (T + V) and the stance contact's normal force where the
model derives one. Files are byte-identical from run to run (fixed zip dates in ``.npz``,
a fixed header in ``.mat``).

A CSV file's first line names the columns; its second is ``#`` followed by each column's
unit, comma-separated in the same order (empty where a column has none), so a reader that
skips ``#`` lines reads the data unchanged: ``numpy.genfromtxt(path, delimiter=",",
names=True, dtype=None, encoding=None)`` or ``pandas.read_csv(path, comment="#")``; the
units are ``next(csv.reader([lines[1][1:]]))``, ``lines`` the file's lines
(:func:`read_csv_units`).
"""

from __future__ import annotations

import csv
import io
import json
import math
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.runtime import limits, stop
from vsw.runtime.errors import VswInputError

__all__ = [
    "FORMATS",
    "SampledWalk",
    "check_rate",
    "read_csv_units",
    "sample_walk",
    "write_trajectory",
]

FORMATS = (".csv", ".npz", ".mat")
"""File types :func:`write_trajectory` writes, chosen by the path's extension."""

MAX_RATE = 1e6
"""The largest sampling rate, samples per model time unit."""


@dataclass(frozen=True)
class SampledWalk:
    """A walk sampled at ``rate`` (module docstring). Rows are in time order; ``event`` is
    empty for a regular sample, ``"NAME:before"`` or ``"NAME:after"`` at an event."""

    names: tuple[str, ...]
    t: np.ndarray
    step: np.ndarray
    phase: tuple[str, ...]
    states: np.ndarray
    energy: np.ndarray
    normal_force: np.ndarray | None
    event: tuple[str, ...]
    ended: str
    steps_completed: int
    rate: float


def _phase_values(model: HybridModel, kind: str, phase: str, params, states: np.ndarray):
    """A generated function of the phase (``energy``, ``normal_force``) on every row."""
    function = getattr(model.module, f"{phase}_{kind}", None)
    if function is None:
        return None
    with np.errstate(all="ignore"):
        value = function(*params, *np.asarray(states, dtype=float).T)
    return np.broadcast_to(np.asarray(value, dtype=float), (len(states),)).copy()


def check_rate(rate: float) -> None:
    """The sampling rate, checked (also by the CLI before any work)."""
    if not (math.isfinite(rate) and 0 < rate <= MAX_RATE):
        raise VswInputError(f"--rate = {rate:g} must be a number in (0, {MAX_RATE:g}]")


def sample_walk(
    model: HybridModel, params: Sequence[float], start: Sequence[float], steps: int, rate: float
) -> SampledWalk:
    """``steps`` steps from the section state ``start``, sampled ``rate`` times per model
    time unit, with the events' rows (module docstring)."""
    check_rate(rate)
    params = tuple(float(v) for v in params)
    pieces, events, ended = model.continuous_walk(params, np.asarray(start, float), steps)
    rows_expected = (pieces[-1].end * rate if pieces else 0) + 2 * len(events) + len(pieces)
    limits.check(
        f"a trajectory of about {rows_expected:.3g} samples",
        limits.Cost(rows_expected * limits.TRAJECTORY_SECONDS_PER_ROW,
                    rows_expected * limits.TRAJECTORY_BYTES_PER_ROW),
        "use a lower --rate or fewer --steps",
    )  # fmt: skip
    has_force = all(
        hasattr(model.module, f"{phase}_normal_force") for phase in {p.phase for p in pieces}
    )
    by_name = {e["name"]: e for e in model.events}
    # (time, order at an instant: events first, step, phase, state, energy, force, event)
    rows: list[tuple[float, int, int, str, np.ndarray, float, float, str]] = []
    for piece in pieces:
        stop.check()
        first = math.ceil(piece.start * rate - 1e-9)
        last = math.floor(piece.end * rate + 1e-9)
        if piece is not pieces[-1] or ended == "completed":
            # A sample exactly at the phase's end belongs to the next phase (after the reset).
            if last / rate >= piece.end - 1e-12:
                last -= 1
        times = np.arange(first, last + 1) / rate
        if not len(times):
            continue
        states = piece.states(times)
        energy = _phase_values(model, "energy", piece.phase, params, states)
        force = _phase_values(model, "normal_force", piece.phase, params, states)
        for i, time in enumerate(times):
            rows.append((float(time), 1, piece.step, piece.phase, states[i], float(energy[i]),
                         float(force[i]) if force is not None else math.nan, ""))  # fmt: skip
    for step, record in events:
        before_phase = by_name[record.name]["source"]
        after_phase = by_name[record.name]["target"]
        force_before = _phase_values(model, "normal_force", before_phase, params,
                                     record.state_before[None, :])  # fmt: skip
        force_after = _phase_values(model, "normal_force", after_phase, params,
                                    record.state_after[None, :])  # fmt: skip
        rows.append((record.time, 0, step, before_phase, record.state_before,
                     record.energy_before,
                     math.nan if force_before is None else float(force_before[0]),
                     f"{record.name}:before"))  # fmt: skip
        ends_step = by_name[record.name]["ends_step"]
        rows.append((record.time, 0, step + int(ends_step), after_phase, record.state_after,
                     record.energy_after,
                     math.nan if force_after is None else float(force_after[0]),
                     f"{record.name}:after"))  # fmt: skip
    # Time order; at one instant the event's rows (before, then after) come before a
    # regular sample of the phase that starts there.
    order = sorted(range(len(rows)), key=lambda i: (rows[i][0], rows[i][1], i))
    rows = [rows[i] for i in order]
    nx = 2 * model.n
    return SampledWalk(
        names=(*model.coordinates, *model.rates),
        t=np.array([r[0] for r in rows], dtype=float),
        step=np.array([r[2] for r in rows], dtype=np.int64),
        phase=tuple(r[3] for r in rows),
        states=np.array([r[4] for r in rows], dtype=float).reshape(-1, nx),
        energy=np.array([r[5] for r in rows], dtype=float),
        normal_force=np.array([r[6] for r in rows], dtype=float) if has_force else None,
        event=tuple(r[7] for r in rows),
        ended=ended,
        steps_completed=sum(1 for _, r in events if by_name[r.name]["ends_step"]),
        rate=float(rate),
    )


def _columns(walk: SampledWalk) -> list[str]:
    force = ["normal_force"] if walk.normal_force is not None else []
    return ["t", "step", "phase", *walk.names, "energy", *force, "event"]


def column_units(model: HybridModel, walk: SampledWalk) -> dict[str, str]:
    """The unit of every column (the model's units; angles in rad)."""
    state_units = {s["name"]: s["unit"] for s in model.spec["state"]}
    units = {"t": model.units.get("time", ""), "step": "1", "phase": "", "event": ""}
    units.update({n: state_units.get(n, "") for n in walk.names})
    units["energy"] = model.units.get("energy", "")
    units["normal_force"] = model.units.get("force", "")
    return {c: units[c] for c in _columns(walk)}


def _csv_text(model: HybridModel, walk: SampledWalk) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(_columns(walk))
    out.write("#")  # the units' line: a comment to readers that skip '#' lines
    writer.writerow(column_units(model, walk).values())
    for i in range(len(walk.t)):
        force = [repr(float(walk.normal_force[i]))] if walk.normal_force is not None else []
        writer.writerow([repr(float(walk.t[i])), int(walk.step[i]), walk.phase[i],
                         *(repr(float(v)) for v in walk.states[i]),
                         repr(float(walk.energy[i])), *force, walk.event[i]])  # fmt: skip
    return out.getvalue()


def read_csv_units(path: str | Path) -> dict[str, str]:
    """The unit of every column of a CSV file :func:`write_trajectory` wrote."""
    with open(path, newline="") as f:
        names = next(csv.reader([f.readline()]))
        units_line = f.readline()
    if not units_line.startswith("#"):
        raise VswInputError(f"{path}: the second line is not the units' line ('#' first)")
    return dict(zip(names, next(csv.reader([units_line[1:]])), strict=True))


def _arrays(model: HybridModel, params: Sequence[float], walk: SampledWalk) -> dict[str, Any]:
    phases = [p["name"] for p in model.phases]
    arrays: dict[str, Any] = {
        "t": walk.t,
        "step": walk.step,
        "phase": np.array([phases.index(p) for p in walk.phase], dtype=np.int64),
        "phase_names": np.array(phases),
        "state": walk.states,
        "state_names": np.array(walk.names),
        "energy": walk.energy,
        "event": np.array(walk.event),
        "parameters": np.array(params, dtype=float),
        "parameter_names": np.array([p.name for p in model.parameter_table]),
        "units": np.array(json.dumps(column_units(model, walk), sort_keys=True)),
        "rate": np.array(walk.rate),
        "ended": np.array(walk.ended),
    }
    if walk.normal_force is not None:
        arrays["normal_force"] = walk.normal_force
    return arrays


def _npz_bytes(arrays: dict[str, Any]) -> bytes:
    """``np.savez``'s layout with fixed zip dates (np.savez stamps the current time)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as archive:
        for name, value in arrays.items():
            member = io.BytesIO()
            np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            archive.writestr(info, member.getvalue())
    return buffer.getvalue()


_MAT_HEADER = b"MATLAB 5.0 MAT-file, written by vsw (vsw simulate --trajectory)"


def _mat_bytes(arrays: dict[str, Any]) -> bytes:
    """A MATLAB 5 file by SciPy, its 116-byte text header (which carries the time of
    writing) replaced by a fixed one."""
    from scipy.io import savemat

    buffer = io.BytesIO()
    savemat(buffer, arrays, do_compression=False, oned_as="column")
    data = bytearray(buffer.getvalue())
    data[:116] = _MAT_HEADER.ljust(116, b" ")
    return bytes(data)


def write_trajectory(
    path: str | Path, model: HybridModel, params: Sequence[float], walk: SampledWalk
) -> None:
    """Write ``walk`` to ``path`` as CSV, ``.npz`` or ``.mat`` by its extension."""
    suffix = Path(path).suffix.lower()
    if suffix == ".csv":
        Path(path).write_text(_csv_text(model, walk))
    elif suffix == ".npz":
        Path(path).write_bytes(_npz_bytes(_arrays(model, params, walk)))
    elif suffix == ".mat":
        Path(path).write_bytes(_mat_bytes(_arrays(model, params, walk)))
    else:
        raise VswInputError(
            f"--trajectory {str(path)!r}: the extension must be one of {', '.join(FORMATS)}"
        )
