"""Limits on the run time and memory of one call: estimated before any work starts, and
the run time enforced while it runs.

Long computations (``simulate``, ``basin``, the edge checks of a basin, ``sweep``, the gait
search before them: :func:`vsw.gaits.search.search_seconds`) estimate their run time and peak
memory from the work they will do and the arrays they will allocate, and refuse with
:class:`vsw.runtime.errors.VswInputError` (the CLI: exit 2 and one line) what exceeds either
limit. Estimates are coarse; a command that runs past ``VSW_MAX_SECONDS`` anyway is
stopped there (:mod:`vsw.runtime.stop`: exit 2, one line). The limits, and how to raise them:

``VSW_MAX_SECONDS``
    Estimated run time in seconds; default 3600. The estimates come from the per-unit
    costs below, measured on the reference machine (2 cores shared with other work): they
    are coarse, within a factor of a few, and meant to stop runs of days or weeks, not
    to predict how long a run takes.
``VSW_MAX_MEMORY``
    Peak memory of the arrays a call allocates, in bytes with an optional ``K``, ``M``,
    ``G`` or ``T`` suffix (powers of 1024); default 80 % of the memory available when the
    call starts (``MemAvailable`` of ``/proc/meminfo``, or what the cgroup still allows
    when that is less; work below :data:`ALWAYS_FITS_BYTES` is not compared with it).
    Setting it may go beyond the available memory (swap).

Both accept ``inf`` for no limit, and any positive number up to the largest double
(``1.7976931348623157e308``): a run-time limit beyond what the system timer holds is as
good as none (:mod:`vsw.runtime.stop`). Invalid settings (NaN, zero, negative, not a number) are
bad input (VswInputError).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from vsw.runtime.errors import VswInputError

__all__ = [
    "ALWAYS_FITS_BYTES",
    "DEFAULT_MAX_SECONDS",
    "Cost",
    "available_memory",
    "check",
    "format_bytes",
    "max_memory",
    "max_seconds",
]

DEFAULT_MAX_SECONDS = 3600.0
"""Default of ``VSW_MAX_SECONDS``: one hour of estimated run time."""

_DEFAULT_MEMORY_FRACTION = 0.8  # head room for the interpreter, matplotlib, the output

ALWAYS_FITS_BYTES = 32 * 1024**2
"""Work estimated below 32 MiB is not compared with the available memory (only with
``VSW_MAX_MEMORY`` when that is set)."""

# Per-unit costs of the estimates, measured by hand on the reference machine (2026-11, 2
# cores under a load of 2-3 from other work) with time.perf_counter around the calls:
#: one simulated step (two DOP853 phases at rtol 1e-12 plus event refinement): 6.6-11.8 ms
SIMULATE_SECONDS_PER_STEP = 8e-3
#: one stride-map step of the basin test on one array element, per thread: 20-60 ns
BASIN_SECONDS_PER_ELEMENT_STEP = 50e-9
#: one stride-map step of the basin test on one block, whatever its size: 150-170 us
BASIN_SECONDS_PER_BLOCK_STEP = 150e-6
# Memory per simulated step, measured with tracemalloc (peak / steps over 2000 steps),
# plus the CLI's lists and JSON text of q, step periods and lengths (~0.6 kB a step):
#: without the trajectory (record=False): 0.9 kB measured
SIMULATE_BYTES_PER_STEP = 1_500
#: with the trajectory (record=True, what a plot needs): 9.4 kB measured
SIMULATE_BYTES_PER_RECORDED_STEP = 12_000
#: a run of any length (the integrator's working arrays): 0.1-0.15 MB measured
SIMULATE_BYTES_BASE = 256 * 1024

# The engine's models through vsw.dynamics.hybrid, measured by hand on the rimless
# wheel (one coordinate, one phase a step; 2026-11, same machine, load 2-4) and scaled by
# phases x coordinates for other models:
#: one phase of a step of the Poincare map (DOP853 at rtol 1e-12, event location): 4-10 ms
HYBRID_SECONDS_PER_PHASE = 8e-3
#: the gait search beyond its scan (vsw.gaits.search.search_seconds adds the scan's steps): the
#: batch Newton from the completed cells and the orbit solves that confirm the gaits,
#: CasADi's set-up included: 1-8 s (benchmarks/run.py case 12)
SEARCH_SECONDS_FIXED = 4.0
#: one periodic-orbit solve from a nearby orbit, its eigenvalues included: 0.05-0.1 s
HYBRID_SECONDS_PER_ORBIT = 0.1
#: one step (a basin rate, a sweep point) in the command's lists and JSON, tracemalloc
#: peak over 100 and 400 simulated steps: 1.6-2.6 kB
HYBRID_BYTES_PER_STEP = 2_500
# The compiled batch simulator (vsw.dynamics.batch), per phase x coordinate of a step, one thread:
#: 21.6 us a step of the simplest walker (1 phase x 2 coordinates), 74 us of the compass
#: gait: benchmarks/run.py case 10
BATCH_SECONDS_PER_PHASE = 4e-5  # per phase x coordinate: covers the compass gait (37 us)
#: a basin cell: the state, outcome, label and steps, and their JSON text (~100 bytes)
BATCH_BYTES_PER_CELL = 400
# vsw sweep of the ILE (vsw.models.ile.sweep over one parameter, every analysis field, JSON text):
#: per point, 1000 and 10^5 points: 76-91 us
ILE_SWEEP_SECONDS_PER_POINT = 1e-4
#: per point, tracemalloc peak at 1000 and 10^5 points: 4.0-4.1 kB
ILE_SWEEP_BYTES_PER_POINT = 5_000

# Trajectories (vsw.dynamics.trajectories), measured by hand on the compass gait and the biped, 3
# steps at 1e4 samples per time unit (22,040 and 68,038 rows; Intel Xeon):
#: sampling 1.6-3.4 us and CSV text 5.9-6.0 us a row, 7.5-9.4 us together
TRAJECTORY_SECONDS_PER_ROW = 1e-5
#: a row's arrays, Python tuple and CSV text: tracemalloc peak 467-468 B a row
TRAJECTORY_BYTES_PER_ROW = 1_000

_SUFFIXES = {"": 1, "K": 1024, "M": 1024**2, "G": 1024**3, "T": 1024**4}


@dataclass(frozen=True)
class Cost:
    """Estimated run time (s) and peak memory (bytes) of a piece of work.

    ``a + b`` is the cost of ``a`` then ``b``: the times add, the peak is the larger one.
    """

    seconds: float
    nbytes: float

    def __add__(self, other: Cost) -> Cost:
        return Cost(self.seconds + other.seconds, max(self.nbytes, other.nbytes))


def _parse_positive(name: str, text: str, suffixes: dict[str, int]) -> float:
    number, factor = text.strip(), 1
    if number[-1:].isalpha() and number.lower() not in ("inf", "infinity"):
        factor = suffixes.get(number[-1].upper(), 0)  # 0: an unknown suffix fails below
        number = number[:-1]
    try:
        value = float(number) * factor
    except ValueError:
        value = math.nan
    if not value > 0:  # NaN, zero, negative, or an unknown suffix
        units = " with an optional K, M, G or T suffix" if len(suffixes) > 1 else ""
        raise VswInputError(f"{name} must be a positive number{units} or inf, got {text!r}")
    return value


def max_seconds() -> float:
    """The run-time limit: ``VSW_MAX_SECONDS`` or :data:`DEFAULT_MAX_SECONDS`.

    Raises
    ------
    VswInputError
        The variable is set but not a positive number (or ``inf``).
    """
    text = os.environ.get("VSW_MAX_SECONDS", "")
    if not text.strip():
        return DEFAULT_MAX_SECONDS
    return _parse_positive("VSW_MAX_SECONDS", text, {"": 1})


def _read_int(path: str) -> int | None:
    try:
        text = Path(path).read_text().strip()
        return int(text)
    except (OSError, ValueError):
        return None  # absent, unreadable or "max"


def available_memory() -> int | None:
    """Bytes that can be allocated now without swapping, or None where unknown.

    ``MemAvailable`` of ``/proc/meminfo`` (else free physical pages), lowered to what a
    cgroup v2 memory limit still allows.
    """
    available = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    available = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if available is None and hasattr(os, "sysconf"):
        try:
            available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError):
            available = None
    cgroup_max = _read_int("/sys/fs/cgroup/memory.max")
    cgroup_used = _read_int("/sys/fs/cgroup/memory.current")
    if cgroup_max is not None and cgroup_used is not None:
        room = max(cgroup_max - cgroup_used, 0)
        available = room if available is None else min(available, room)
    return available


def max_memory() -> tuple[float, str]:
    """The memory limit in bytes and where it comes from (for messages).

    Returns
    -------
    tuple of (float, str)
        ``(limit, origin)``; ``limit`` is ``inf`` where the available memory is unknown.

    Raises
    ------
    VswInputError
        ``VSW_MAX_MEMORY`` is set but not a positive size (or ``inf``).
    """
    text = os.environ.get("VSW_MAX_MEMORY", "")
    if text.strip():
        return _parse_positive("VSW_MAX_MEMORY", text, _SUFFIXES), "VSW_MAX_MEMORY"
    available = available_memory()
    if available is None:
        return math.inf, "unknown available memory"
    return (
        _DEFAULT_MEMORY_FRACTION * available,
        f"{_DEFAULT_MEMORY_FRACTION:.0%} of the {format_bytes(available)} available",
    )


def format_bytes(n: float) -> str:
    """``n`` bytes in a short human form (powers of 1024)."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1024
    raise AssertionError("unreachable")


def _format_seconds(s: float) -> str:
    if not math.isfinite(s):
        return "forever"
    for unit, size in (("days", 86400), ("h", 3600), ("min", 60)):
        if s >= size:
            return f"{s / size:.3g} {unit}"
    return f"{s:.3g} s"


def check(what: str, cost: Cost, remedy: str) -> None:
    """Refuse work whose estimated time or memory exceeds the limits.

    Parameters
    ----------
    what : str
        The work, for the message (e.g. ``"simulating 1000000000 steps"``).
    cost : Cost
        Its estimate.
    remedy : str
        How to make it smaller, in the caller's terms (e.g. ``"use fewer --steps"``).

    Raises
    ------
    VswInputError
        One line: the estimate, the limit, the remedy and the variable that raises it.
    """
    # Reading /proc/meminfo costs ~0.2 ms, as much as the work of a one-step simulation:
    # small work is compared with the available memory only when VSW_MAX_MEMORY is set.
    if cost.nbytes > ALWAYS_FITS_BYTES or os.environ.get("VSW_MAX_MEMORY", "").strip():
        limit, origin = max_memory()
    else:
        limit, origin = math.inf, ""
    if not cost.nbytes <= limit:
        raise VswInputError(
            f"{what} needs about {format_bytes(cost.nbytes)} of memory, more than the limit "
            f"of {format_bytes(limit)} ({origin}); {remedy}, or raise the limit with "
            "VSW_MAX_MEMORY (e.g. VSW_MAX_MEMORY=64G)"
        )
    seconds = max_seconds()
    if not cost.seconds <= seconds:
        raise VswInputError(
            f"{what} would take about {_format_seconds(cost.seconds)}, more than the limit of "
            f"{_format_seconds(seconds)}; {remedy}, or raise the limit with VSW_MAX_SECONDS "
            "(in seconds, inf for none)"
        )
