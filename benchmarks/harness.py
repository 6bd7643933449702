"""What every benchmark case shares: the timings and rows it reports, the side-by-side
timer, the memory it measures, the BLAS threading it runs under and a checkout of an
earlier commit. Importing it puts the repository (and the tests' oracles) on the path."""

from __future__ import annotations

import contextlib
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
# The tests' oracles (tests/oracles: routes the runtime does not ship) are case 3's subject.
if str(ROOT / "tests") not in sys.path:
    sys.path.append(str(ROOT / "tests"))


@dataclass
class Timing:
    median: float
    low: float
    high: float

    @classmethod
    def of(cls, samples: list[float]) -> Timing:
        return cls(statistics.median(samples), min(samples), max(samples))

    def per(self, count: int) -> Timing:
        return Timing(self.median / count, self.low / count, self.high / count)


@dataclass
class Row:
    case: str
    subject: str
    baseline: str
    subject_time: Timing | None
    baseline_time: Timing | None
    target: str
    met: bool | None
    note: str = ""
    subject_peak_mb: float | None = None
    baseline_peak_mb: float | None = None
    extra: dict = field(default_factory=dict)

    @property
    def ratio(self) -> float | None:
        if self.subject_time is None or self.baseline_time is None:
            return None
        return self.subject_time.median / self.baseline_time.median

    @classmethod
    def from_dict(cls, d: dict) -> Row:
        d = dict(d)
        d.pop("ratio", None)
        for key in ("subject_time", "baseline_time"):
            if d[key] is not None:
                d[key] = Timing(**d[key])
        return cls(**d)


def interleaved(a: Callable, b: Callable, repetitions: int) -> tuple[Timing, Timing]:
    """Time ``a`` and ``b`` alternately after one warm-up call of each."""
    a()
    b()
    ta, tb = [], []
    for _ in range(repetitions):
        for fn, sink in ((a, ta), (b, tb)):
            start = time.perf_counter()
            fn()
            sink.append(time.perf_counter() - start)
    return Timing.of(ta), Timing.of(tb)


def timed(fn: Callable, repetitions: int) -> Timing:
    fn()
    samples = []
    for _ in range(repetitions):
        start = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - start)
    return Timing.of(samples)


def peak_alloc_mb(fn: Callable) -> float:
    """Peak memory traced during one call of ``fn`` (numpy buffers included), in MB."""
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def blas_threading() -> str:
    """The BLAS threading of this process, which the processes it starts inherit: each BLAS
    that numpy and SciPy load (threadpoolctl) with its thread count outside any limit of
    vsw's, and the environment variables that set the counts."""
    import scipy.linalg  # noqa: F401  (SciPy's own BLAS, loaded with it)
    from threadpoolctl import threadpool_info

    libraries = [f"{i['internal_api']} {i['version']} on {i['num_threads']} threads"
                 for i in threadpool_info() if i["user_api"] == "blas"]  # fmt: skip
    names = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
    given = [f"{n}={os.environ[n]}" for n in names if n in os.environ]
    settings = ", ".join(given) if given else "OPENBLAS_NUM_THREADS and OMP_NUM_THREADS unset"
    return f"BLAS: {', '.join(libraries) or 'none found'} ({settings})"


@contextlib.contextmanager
def _checkout(ref: str):
    """A detached worktree of ``ref`` in a temporary directory (removed after)."""
    with tempfile.TemporaryDirectory() as parent:
        tree = Path(parent) / "tree"
        subprocess.run(["git", "worktree", "add", "--detach", str(tree), ref], cwd=ROOT,
                       check=True, capture_output=True)  # fmt: skip
        try:
            yield tree
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                           capture_output=True)  # fmt: skip
