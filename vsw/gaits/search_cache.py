"""The gait search's kept searches: where a search is kept (its key), its seal (the SHA-256
of its canonical content), reading, validating and writing it, and the record of its
confirmed gaits.

A search (:func:`vsw.gaits.search.search`) keeps its scan and Newton's solutions, then its
confirmed gaits, in ``<cache dir>/searches/`` (:func:`cache_file`; ``VSW_SEARCH_CACHE=0``
turns it off), so that a later search of the same model, code and inputs returns the same
gaits without scanning again. What is read back is trusted only as far as it is checked
here: the file's seal (its own name and the SHA-256 of the rest) and its fields (types,
ranges, the grid, the routes and outcomes); a file that fails is ignored with a one-line
:class:`~vsw.runtime.errors.CacheWarning` (:func:`note`). The search then steps each kept gait
once more (:func:`vsw.gaits.search.recheck`): that part needs the search's own machinery and stays
with it. Kept apart from :mod:`vsw.gaits.search` so that the search reads as the search; it
imports nothing of the search (the search's code is part of the key by its file).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import math
import os
import tempfile
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from vsw.dynamics import batch, hybrid
from vsw.dynamics.batch import BatchSimulator
from vsw.dynamics.compiled import cache_dir
from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.orbits import newton
from vsw.runtime.errors import CacheWarning

__all__ = [
    "cache_file",
    "casadi_fingerprint",
    "confirmed_record",
    "content_digest",
    "kept_gaits",
    "note",
    "read",
    "write",
]

_CACHE_KEYS = {"found", "points", "outcomes", "candidates", "converged", "route"}
"""A kept scan's keys; ``confirmed`` beside them once its gaits are confirmed."""

_SEAL_KEYS = {"file", "sha256"}
"""And the seal of every kept file: its own name and the SHA-256 of the rest
(:func:`content_digest`), so that a file altered, or copied under another search's name,
is not read as a search."""

_GAIT_KEYS = {"state", "period", "phase_durations", "eigenvalues", "max_abs_eigenvalue",
              "stable", "step_length", "speed", "residual"}  # fmt: skip
"""A kept gait's keys (:meth:`Orbit.to_dict`)."""


def confirmed_record(
    gaits: list[Orbit], unconfirmed: list[dict[str, Any]], standing: int
) -> dict[str, Any] | None:
    """Step 4's result as JSON (each gait's :meth:`Orbit.to_dict`), or None where a gait
    carries its phases' states, which the record does not keep."""
    if any(o.phase_states for o in gaits):
        return None
    return {"casadi": casadi_fingerprint(), "gaits": [o.to_dict() for o in gaits],
            "unconfirmed": unconfirmed, "standing": standing}  # fmt: skip


def kept_gaits(record: Any, names: list[str]) -> tuple[list[Orbit], list[dict], int] | None:
    """:func:`confirmed_record` read back (validated by :func:`read`), or None
    (none kept, or kept with another CasADi installation: the gaits are confirmed again)."""
    if not isinstance(record, dict) or record.get("casadi") != casadi_fingerprint():
        return None
    gaits = [
        Orbit(
            state={name: float(o["state"][name]) for name in names},
            durations=tuple(float(v) for v in o["phase_durations"]),
            period=float(o["period"]),
            eigenvalues=tuple(complex(re, im) for re, im in o["eigenvalues"]),
            step_length=None if o["step_length"] is None else float(o["step_length"]),
            residual=float(o["residual"]),
        )
        for o in record["gaits"]
    ]
    return gaits, record["unconfirmed"], record["standing"]


def casadi_fingerprint() -> str:
    """CasADi's installation (its folder, and the name, size and time of each of its
    libraries: the extension, the core and the plugins the boundary-value solver loads),
    which the confirmed gaits depend on and the scan does not; without importing it (15
    ms)."""
    spec = importlib.util.find_spec("casadi")
    if spec is None or spec.origin is None:
        return "no casadi"
    folder = Path(spec.origin).parent
    files = sorted(f for f in folder.iterdir() if "casadi" in f.name and ".so" in f.name)
    stats = [(f.name, f.stat().st_size, f.stat().st_mtime_ns) for f in files]
    return hashlib.sha256(repr((str(folder), stats)).encode()).hexdigest()[:24]


def cache_file(
    model: HybridModel, sim: BatchSimulator, params: tuple[float, ...],
    box: dict[str, tuple[float, float]], cells: int | None,
) -> Path | None:  # fmt: skip
    """Where a search is kept: ``<cache dir>/searches/<model>-<key>.json``, the key a SHA-256
    of everything the search depends on (the model package's Python files, the compiled
    simulator's file, whose name is the hash of its C source, flags, compiler and CPU, the
    search's and this module's, the batch simulator's, vsw.dynamics.hybrid's and vsw.orbits' code,
    numpy's version, the parameters, the box and the cells; the confirmed gaits kept in it
    carry CasADi's installation, :func:`kept_gaits`). Files are never removed: delete the
    directory to reclaim it. None with ``VSW_SEARCH_CACHE=0`` or no compiled simulator."""
    if os.environ.get("VSW_SEARCH_CACHE", "1").strip() == "0" or sim.library_path is None:
        return None
    package = Path(model.module.__file__).parent
    parts = [
        *(f.read_bytes() for f in sorted(package.rglob("*.py")) if "__pycache__" not in f.parts),
        sim.library_path.name.encode(),
        Path(__file__).with_name("search.py").read_bytes(),  # the search's code
        Path(__file__).read_bytes(),
        Path(batch.__file__).read_bytes(),
        Path(hybrid.__file__).read_bytes(),  # the integrator's tolerances the batch takes
        # Newton and the boundary-value solver the gaits are found and confirmed by.
        *(f.read_bytes() for f in sorted(Path(newton.__file__).parent.glob("*.py"))),
        np.__version__.encode(),
        repr((params, sorted(box.items()), cells)).encode(),
    ]
    key = hashlib.sha256(b"\0".join(parts)).hexdigest()[:24]
    return cache_dir() / "searches" / f"{model.name}-{key}.json"


def note(text: str) -> None:
    """Say that a kept search is not used, and why (a :class:`~vsw.runtime.errors.CacheWarning`:
    one line on the CLI's stderr, whose own stream solver work redirects)."""
    warnings.warn(text, CacheWarning, stacklevel=3)


def content_digest(content: Mapping[str, Any]) -> str:
    """SHA-256 of ``content`` as canonical JSON (keys sorted, no spaces; the floats as
    ``repr`` writes them, which reads back exactly). ValueError for a number that is not
    finite (none is kept)."""
    text = json.dumps(content, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def read(
    path: Path | None, model: HybridModel, sim: BatchSimulator,
    box: dict[str, tuple[float, float]], per_axis: int,
) -> dict[str, Any] | None:  # fmt: skip
    """A kept scan (with its confirmed gaits, if kept), or None: none kept, or one that is
    not trusted (unreadable, its digest or name not its own, a field of the wrong type or
    range: a note says which) is made again."""
    if path is None:
        return None
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        problem = "not JSON" if isinstance(exc, ValueError) else "unreadable"
    else:
        problem = _sealed(data, path) or _invalid(data, model, sim, box, per_axis)
    if problem is not None:
        note(f"the kept search {path} is ignored ({problem}): searching again")
        return None
    return {k: v for k, v in data.items() if k not in _SEAL_KEYS}


def _sealed(data: Any, path: Path) -> str | None:
    """Why ``data`` is not a kept file's own content (:data:`_SEAL_KEYS`), or None."""
    if not isinstance(data, dict) or set(data) - {"confirmed"} != _CACHE_KEYS | _SEAL_KEYS:
        return "not a kept search's fields"
    try:
        digest = content_digest({k: v for k, v in data.items() if k != "sha256"})
    except ValueError:
        return "a number that is not finite"
    if data["sha256"] != digest:
        return "its SHA-256 does not match its content"
    if data["file"] != path.name:
        return "written as another search's file"
    return None


def _count(value: Any, low: int = 0, high: float = math.inf) -> bool:
    """Whether ``value`` is an integer (not a bool) in [low, high]."""
    return type(value) is int and low <= value <= high


def _number(value: Any) -> bool:
    """Whether ``value`` is a finite JSON number (not a bool)."""
    return type(value) in (int, float) and math.isfinite(value)


def _states(value: Any, names: list[str]) -> bool:
    """Whether ``value`` is a state: these names in this order, finite numbers."""
    return isinstance(value, dict) and list(value) == names and all(map(_number, value.values()))


def _invalid(
    data: dict[str, Any], model: HybridModel, sim: BatchSimulator,
    box: dict[str, tuple[float, float]], per_axis: int,
) -> str | None:  # fmt: skip
    """Why a kept search's fields are not what the search's scan and confirmation write
    for this search (types, ranges, the grid of ``per_axis`` points along each of the box's
    components, the routes), or None."""
    free = list(box)
    points = data["points"]
    if not (isinstance(points, dict) and list(points) == free
            and all(type(v) is int and v == per_axis for v in points.values())):  # fmt: skip
        return "its grid is not this search's"
    outcomes = data["outcomes"]
    known = {"walked", "stalled", *sim.failures}
    if not (isinstance(outcomes, dict) and set(outcomes) <= known
            and all(map(_count, outcomes.values()))
            and sum(outcomes.values()) == per_axis ** len(free)):  # fmt: skip
        return "its scan's outcomes are not counts of its cells"
    candidates, converged, found = data["candidates"], data["converged"], data["found"]
    if not (_count(candidates, 0, outcomes.get("walked", 0)) and _count(converged, 0, candidates)):
        return "its counts of Newton's starts are out of range"
    if not (isinstance(found, list) and len(found) <= converged
            and all(isinstance(y, list) and len(y) == len(free) and all(map(_number, y))
                    for y in found)):  # fmt: skip
        return "its Newton solutions are not states of the search box's components"
    if (len(found) == 0) != (converged == 0):  # converged starts leave one solution at least
        return "its Newton solutions do not match its count of converged starts"
    route = data["route"]
    scipy = isinstance(route, str) and route.startswith("SciPy (") and route.endswith(")")
    if not (route == "compiled" or (scipy and "\n" not in route)):
        return "its route is not one of the batch simulator's"
    record = data.get("confirmed")
    if record is None:
        return None
    names = [*model.coordinates, *model.rates]
    if not (isinstance(record, dict) and set(record) == {"casadi", "gaits", "unconfirmed",
                                                         "standing"}
            and isinstance(record["casadi"], str) and isinstance(record["gaits"], list)
            and isinstance(record["unconfirmed"], list)):  # fmt: skip
        return "its confirmed gaits are not a record of them"
    for o in record["gaits"]:
        problem = _invalid_gait(o, names, 2 * model.n)
        if problem is not None:
            return f"a kept gait: {problem}"
    for u in record["unconfirmed"]:
        if not (isinstance(u, dict) and set(u) == {"state", "period", "reason"}
                and _states(u["state"], names) and _number(u["period"]) and u["period"] > 1e-9
                and isinstance(u["reason"], str)):  # fmt: skip
            return "an unconfirmed solution is not a record of one"
    taken = len(record["gaits"]) + len(record["unconfirmed"])
    if not _count(record["standing"], 0, len(found) - taken):
        return "more gaits, unconfirmed and standing solutions than Newton solutions"
    return None


def _invalid_gait(o: Any, names: list[str], size: int) -> str | None:
    """Why ``o`` is not a gait's record (:meth:`Orbit.to_dict`) of a state of ``names``
    and ``size`` eigenvalues, or None."""
    if not (isinstance(o, dict) and set(o) == _GAIT_KEYS and _states(o["state"], names)):
        return "not a gait's record"
    durations, period = o["phase_durations"], o["period"]
    if not (isinstance(durations, list) and durations and all(map(_number, durations))
            and min(durations) > 0 and _number(period)
            and abs(period - math.fsum(durations)) <= 1e-12 * period):  # fmt: skip
        return "its period is not the sum of positive phase durations"
    eigenvalues = o["eigenvalues"]
    if not (isinstance(eigenvalues, list) and len(eigenvalues) == size
            and all(isinstance(e, list) and len(e) == 2 and all(map(_number, e))
                    for e in eigenvalues)):  # fmt: skip
        return f"not {size} eigenvalues"
    length = o["step_length"]
    if not (length is None or _number(length)):
        return "its step length is not a number"
    scale = max(1.0, *(abs(v) for v in o["state"].values()))
    if not (_number(o["residual"]) and 0 <= o["residual"] <= 1e-9 * scale):
        return "its residual is above the orbit solver's tolerance"
    return None


def write(path: Path | None, content: dict[str, Any]) -> None:
    """Keep a search, sealed (:data:`_SEAL_KEYS`; written whole, then renamed: a reader
    never sees part of it); a cache that cannot be written is no error."""
    if path is None:
        return
    try:
        sealed = {**content, "file": path.name}
        sealed["sha256"] = content_digest(sealed)
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=path.parent, delete=False,
                                         prefix=".search-", suffix=".json") as handle:  # fmt: skip
            json.dump(sealed, handle)
        os.replace(handle.name, path)
    except (OSError, ValueError):
        with contextlib.suppress(OSError, UnboundLocalError):
            os.unlink(handle.name)
