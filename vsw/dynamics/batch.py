"""The batch simulator: many walks of one engine model in one compiled call.

``python -m derive`` writes each engine model's hybrid dynamics as a C table
(``generated/<model>/c/<model>_sim.c``: phase flows, watched guards, resets, ``when``
conditions, step length); :mod:`vsw.dynamics.batch` compiles it with the generic integrator
``vsw/dynamics/csrc/hybrid_batch.c`` (DOP853 with SciPy's step control, event location by the
Illinois method on the guard to 1e-13 in time, the SciPy route's event rules) into the
kernel cache (:func:`vsw.models.ile.kernels.build_library`) and runs blocks of walks on threads
(:func:`vsw.runtime.vectorize.run_blocks`; each ctypes call releases the GIL), or as tasks on a
Dask cluster (:mod:`vsw.studies.cluster`). Each walk ends with its outcome: converged to a given
gait, a period-k orbit, fell (which failure), stalled, or walked every step.

Without a C compiler (or with ``VSW_KERNELS=0``) the same walks run through the SciPy
route, :meth:`vsw.dynamics.hybrid.HybridModel.step`, one at a time: the same classes, much slower.
:func:`reference_walks` is that route, and the tests compare the two.
"""

from __future__ import annotations

import ctypes
import math
import os
import platform
import sys
import threading
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsw.dynamics.compiled import build_library
from vsw.dynamics.hybrid import (
    ATOL,
    PHASE_TIME_LIMIT,
    RTOL,
    EventRecord,
    HybridModel,
    StepResult,
    Trajectory,
)
from vsw.runtime import blas, progress, stop
from vsw.runtime.errors import ConvergenceError, SlowRouteWarning, VswInputError
from vsw.runtime.threads import default_threads
from vsw.runtime.vectorize import run_blocks

__all__ = ["BatchResult", "BatchSimulator", "reference_walks", "simulator"]

CSRC = Path(__file__).resolve().parent / "csrc"

WALKED, CONVERGED, FELL, STALLED, PERIODIC = range(5)
"""Outcome codes of vsw/dynamics/csrc/hybrid_batch.c."""

CHUNK = 256
"""Walks per block: small enough to balance threads over cells that fall at once and cells
that walk every step, large enough that a ctypes call costs nothing beside it."""

# No FMA contraction: the same sums in the same order in every build (the lanes and the
# scalar code round alike). Hidden symbols but the entry points: the compiler may inline
# the model's functions. The first build takes its sines and cosines from glibc's vector
# math library where the CPU has AVX2 (vsw/dynamics/csrc/lanes.h); without libmvec the next takes
# libm's, and so does the plain -O2 build: values a few ulp apart from the first's.
# libmvec is offered only where it can exist (x86-64 Linux with glibc): elsewhere a failed
# link would cost every new process a full compile before the next flag set.
_COMMON_FLAGS = ["-ffp-contract=off", "-fvisibility=hidden", "-lm"]
_NATIVE_FLAGS = ["-O3", "-march=native", "-fno-math-errno"]
_HAS_LIBMVEC = (
    sys.platform.startswith("linux")
    and platform.machine() in ("x86_64", "AMD64")
    and "glibc" in (os.confstr("CS_GNU_LIBC_VERSION") if "CS_GNU_LIBC_VERSION" in os.confstr_names
                    else "")
)  # fmt: skip
_VECTOR_FLAGS = [*_NATIVE_FLAGS, *_COMMON_FLAGS, "-lmvec"]
_LIBM_FLAGS = [*_NATIVE_FLAGS, "-DVSW_NO_MVEC", *_COMMON_FLAGS]
_PORTABLE_FLAGS = ["-O2", *_COMMON_FLAGS]
_FLAG_SETS = (*([_VECTOR_FLAGS] if _HAS_LIBMVEC else []), _LIBM_FLAGS, _PORTABLE_FLAGS)

STEPS_PER_CALL = 32
"""Steps a call of :meth:`BatchSimulator.walk_varying` walks: enough that the calls, the
blocks' ends and the drawing of rows between calls cost little beside the steps, few
enough that the rows drawn past a walk's failure (half a call's, on average) do too."""
VARYING_BYTES = 1 << 26
"""The most parameter rows of one call of walk_varying, in bytes (fewer steps a call for
millions of walks)."""

DEFAULT_CONVERGE_TOL = 1e-6
DEFAULT_PERIOD_TOL = 1e-6
DEFAULT_MAX_PERIOD = 8
APART = 100.0
"""A period-k cycle's points are more than this times the period tolerance apart (as
VSW_APART in hybrid_batch.c): a walk spiralling into a fixed point also comes back near
itself after a few steps."""


@dataclass
class BatchResult:
    """The walks of one batch, one row per walk.

    ``outcome``: the codes WALKED, CONVERGED, FELL, STALLED, PERIODIC; ``aux``: the
    failure's index into ``failures`` (FELL) or the period (PERIODIC); ``steps``: steps
    walked; ``final``: the last section state; ``kept_*``: the last ``keep`` steps'
    section states, step lengths and durations (oldest first; NaN rows where fewer steps
    were walked).
    """

    outcome: np.ndarray
    aux: np.ndarray
    steps: np.ndarray
    final: np.ndarray
    kept_states: np.ndarray
    kept_lengths: np.ndarray
    kept_durations: np.ndarray
    failures: tuple[str, ...]
    route: str = "compiled"
    """How the walks ran: ``compiled``, or why (some of) them took the SciPy route."""

    def labels(self) -> list[str]:
        """``converged``, ``period-K``, ``fell`` or ``other`` (walked every step without
        settling, or stalled), per walk."""
        return self._named(self._label)

    def ended(self) -> list[str]:
        """What ended each walk: ``converged``, ``period-K``, the failure's name,
        ``stalled`` or ``walked``."""
        return self._named(self._ending)

    def _named(self, name: Callable[[int, int], str]) -> list[str]:
        """``name(outcome, aux)`` per walk, computed once per distinct pair (a 200 x 200
        basin has a handful): a Python loop over the walks took 40 ms of `vsw basin`."""
        # One integer per pair (aux, a failure's index or a period, in its low 32 bits): a
        # one-dimensional unique sorts ten times faster than unique over pairs.
        outcome, aux = np.asarray(self.outcome, np.int64), np.asarray(self.aux, np.int64)
        _, first, index = np.unique(outcome << 32 | (aux & 0xFFFFFFFF), return_index=True,
                                    return_inverse=True)  # fmt: skip
        names = [name(int(outcome[i]), int(aux[i])) for i in first]
        return np.array(names, dtype=object)[index.ravel()].tolist()

    @staticmethod
    def _label(code: int, aux: int) -> str:
        if code == CONVERGED:
            return "converged"
        if code == PERIODIC:
            return f"period-{aux}"
        return "fell" if code == FELL else "other"

    def _ending(self, code: int, aux: int) -> str:
        if code == FELL:
            return self.failures[aux]
        if code == STALLED:
            return "stalled"
        return "walked" if code == WALKED else self._label(code, aux)

    @staticmethod
    def concatenate(parts: Sequence[BatchResult]) -> BatchResult:
        fields = ("outcome", "aux", "steps", "final", "kept_states", "kept_lengths",
                  "kept_durations")  # fmt: skip
        joined = {f: np.concatenate([getattr(p, f) for p in parts]) for f in fields}
        routes = sorted({p.route for p in parts if p.route != "compiled"})
        return BatchResult(**joined, failures=parts[0].failures,
                           route="; ".join(routes) or "compiled")  # fmt: skip


def failure_names(model: HybridModel) -> tuple[str, ...]:
    """The model's failures in the order of first appearance: the C table's indices
    (derive/sim_codegen.py, ``failure_names``)."""
    names: list[str] = []
    for phase in model.phases:
        for name, _function, _direction in (*phase["failures"], *phase.get("start_failures", ())):
            if name not in names:
                names.append(name)
    return tuple(names)


class BatchSimulator:
    """The compiled batch simulator of one engine model (see the module docstring)."""

    def __init__(self, model: HybridModel) -> None:
        self.model = model
        self._label = getattr(model, "cli_name", model.name)
        self.failures = failure_names(model)
        self.nx = 2 * model.n
        self.np = len(model.spec["parameters"])
        self._lib: ctypes.CDLL | None = None
        self.build_error: str | None = None
        self._lock = threading.Lock()
        self._tried = False
        self.library_path: Path | None = None  # the compiled library's file, once built

    @property
    def source(self) -> Path:
        return Path(self.model.module.__file__).parent / "c" / f"{self.model.name}_sim.c"

    def c_source(self) -> bytes:
        """The library's C text: the model's table, then the integrator."""
        return self.source.read_bytes() + b"\n" + (CSRC / "hybrid_batch.c").read_bytes()

    def use_build(self, source: bytes, stem: str, flag_sets: Sequence[list[str]]) -> ctypes.CDLL:
        """Walk with a library built from ``source`` (a variant of :meth:`c_source`: other
        flags, lanes or counters; benchmarks and tests) instead of the default one."""
        lib, self.library_path = build_library(source, stem, tuple(flag_sets), includes=(CSRC,))
        self._bind(lib)
        self._lib, self._tried = lib, True
        return lib

    def library(self) -> ctypes.CDLL | None:
        """The compiled simulator, built on first call; None when unavailable (then
        :attr:`build_error` says why and the walks take the SciPy route)."""
        if os.environ.get("VSW_KERNELS", "1").strip() == "0":
            self.build_error = "VSW_KERNELS=0"
            return None
        with self._lock:
            if not self._tried:
                self._tried = True
                try:
                    lib, self.library_path = build_library(
                        self.c_source(), f"{self.model.name}_sim", _FLAG_SETS, includes=(CSRC,)
                    )
                    self._bind(lib)
                    self._lib = lib
                    stop.register(lambda: lib.vsw_batch_stop(1), lambda: lib.vsw_batch_stop(0))
                except (OSError, AttributeError) as exc:
                    self.build_error = f"batch simulator unavailable, using SciPy: {exc}"
                    warnings.warn(
                        f"the compiled batch simulator of {self._label} is unavailable "
                        f"({' '.join(str(exc).split())[:200]}); walking with SciPy instead, "
                        "about 300 times slower",
                        SlowRouteWarning,
                        stacklevel=2,
                    )
        return self._lib

    def _bind(self, lib: ctypes.CDLL) -> None:
        sizes = (ctypes.c_longlong * 4)()
        lib.vsw_batch_sizes(sizes)
        expected = (self.np, self.nx, len(self.model.phases), len(self.model.events))
        if tuple(sizes) != expected:  # a table from another derivation than the descriptor
            raise OSError(f"{self.source.name} has sizes {tuple(sizes)}, the model {expected}")
        dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
        i32 = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
        i64 = np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS")
        lib.vsw_batch_stop.argtypes = [ctypes.c_int]
        lib.vsw_batch_stop.restype = None
        fn = lib.vsw_batch_simulate
        fn.restype = None
        ll = ctypes.c_longlong
        fn.argtypes = [ll, dbl, ll, dbl, dbl, ctypes.c_void_p, ll, ll, ll, i32, i32, i64, dbl,
                       dbl, dbl, dbl]  # fmt: skip

    # --- walks -------------------------------------------------------------------------

    def walk(
        self,
        params: Sequence[float] | np.ndarray,
        states: np.ndarray,
        steps: int,
        *,
        target: Sequence[float] | None = None,
        converge_tol: float = DEFAULT_CONVERGE_TOL,
        period_tol: float = DEFAULT_PERIOD_TOL,
        max_period: int = DEFAULT_MAX_PERIOD,
        keep: int = 0,
        threads: int | None = None,
        runner: Runner | None = None,
        tolerance: float = RTOL,
    ) -> BatchResult:
        """Walk every row of ``states`` (section states, shape (N, 2n)) up to ``steps``
        steps, stopping early when it converges to ``target`` (every component within
        ``converge_tol * max(1, |target|)``), repeats itself with a period 2..``max_period``
        (1 too without a target) to ``period_tol * max(1, |state|)`` with the cycle's points
        apart (:data:`APART`), falls or stalls.
        ``params``: one parameter vector for all, or one row per walk. ``converge_tol`` or
        ``period_tol`` 0 turns that check off. ``keep``: record the last ``keep`` steps.
        ``runner``: where the walks run instead of this process's threads, e.g.
        :func:`vsw.studies.cluster.runner` (a Dask scheduler), with results identical to the local
        ones. ``tolerance``: the integrator's
        rtol = atol (default 1e-12, the SciPy route's).
        """
        states = np.asarray(states, dtype=float)
        if states.ndim != 2 or states.shape[1] != self.nx:
            raise VswInputError(
                f"states must have shape (N, {self.nx}) for {self.model.name}, got {states.shape}"
            )
        states = np.ascontiguousarray(states)
        params = np.asarray(params, dtype=float)
        if params.ndim == 2 and params.shape[1] != self.np:
            raise VswInputError(f"parameter rows must have {self.np} values, got {params.shape}")
        if target is not None and np.shape(target) != (self.nx,):
            raise VswInputError(f"target must have {self.nx} components, got {np.shape(target)}")
        if params.ndim == 1:
            if params.size != self.np:
                raise VswInputError(
                    f"{self.model.name} takes {self.np} parameters, got {params.size}"
                )
            params = np.broadcast_to(params, (len(states), self.np))
        params = np.ascontiguousarray(params.reshape(-1, self.np))
        if len(params) != len(states):
            raise VswInputError(f"{len(params)} parameter rows for {len(states)} states")
        if steps < 0 or keep < 0 or max_period < 0:
            raise VswInputError("steps, keep and max_period must be >= 0")
        max_period = min(int(max_period), 64)
        if not 1e-15 <= tolerance <= 1e-3:
            raise VswInputError(f"tolerance = {tolerance:g} must lie in [1e-15, 1e-3]")
        options = Options(steps, None if target is None else tuple(float(v) for v in target),
                          converge_tol, period_tol, max_period, keep, tolerance)  # fmt: skip
        if runner is not None:
            return runner(params, states, options)
        return self.walk_here(params, states, options, threads)

    def walk_here(self, params, states, options: Options, threads: int | None) -> BatchResult:
        """The walks of :meth:`walk` on this process's threads."""
        threads = default_threads() if threads is None else threads
        lib = self.library()
        if lib is None:
            result = reference_walks(self.model, params, states, options)
            result.route = f"SciPy ({self.build_error})"
            return result
        n = len(states)
        keep = options.keep
        out = _empty_result(n, self.nx, keep, self.failures)
        opts = np.array([options.tolerance, options.tolerance, PHASE_TIME_LIMIT,
                         options.converge_tol, options.period_tol], dtype=float)  # fmt: skip
        target = None
        if options.target is not None:
            target = np.ascontiguousarray(options.target, dtype=float)
        target_ptr = None if target is None else target.ctypes.data_as(ctypes.c_void_p)
        fn = lib.vsw_batch_simulate

        def block(start: int) -> None:
            stop = min(start + CHUNK, n)
            part = _empty_result(stop - start, self.nx, keep, self.failures)
            fn(stop - start, params[start:stop], self.np, states[start:stop], opts, target_ptr,
               options.steps, options.max_period, keep, part.outcome, part.aux, part.steps,
               part.final, part.kept_states, part.kept_lengths, part.kept_durations)  # fmt: skip
            for name in ("outcome", "aux", "steps", "final", "kept_states", "kept_lengths",
                         "kept_durations"):  # fmt: skip
                getattr(out, name)[start:stop] = getattr(part, name)

        with blas.limited(threads):  # the walks call no BLAS: a call beside them keeps to it
            run_blocks(block, range(0, n, CHUNK), threads)
        return out

    def walk_varying(
        self,
        step_params: Callable[[np.ndarray, int], np.ndarray],
        states: np.ndarray,
        steps: int,
        *,
        threads: int | None = None,
        tolerance: float = RTOL,
    ) -> BatchResult:
        """Walk every row of ``states`` up to ``steps`` steps, each step with parameters of
        its own: step ``k`` (from 0) of the walks still walking takes the parameter rows
        ``step_params(walks, k)`` (``walks``: their row indices, ascending), e.g. a slope
        drawn at each step event (:mod:`vsw.studies.rough`). A walk ends WALKED (every step), FELL
        or STALLED; no convergence or period checks, nothing kept.

        The compiled simulator walks up to :data:`STEPS_PER_CALL` steps a call, each walk
        with its rows of those steps, and stops each at its first failure; where
        ``step_params`` has a method ``of_steps(walks, first, count)`` (the rows of steps
        ``first .. first + count - 1``, shape (len(walks), count, parameters): its calls
        stacked on axis 1) it gives them, else its calls do. Each step is the one a call of
        :meth:`walk` of one step would take from the state the last ended in, so a walk's
        result depends on its own rows alone (not on the thread count, the blocks, the
        steps a call or the other walks). Without the compiled simulator each step is such
        a call (the SciPy route). Progress is reported by steps
        (:func:`vsw.runtime.progress.report`), not by each call's blocks."""
        states = np.array(states, dtype=float)
        if states.ndim != 2 or states.shape[1] != self.nx:
            raise VswInputError(
                f"states must have shape (N, {self.nx}) for {self.model.name}, got {states.shape}"
            )
        if not 1e-15 <= tolerance <= 1e-3:
            raise VswInputError(f"tolerance = {tolerance:g} must lie in [1e-15, 1e-3]")
        out = _empty_result(len(states), self.nx, 0, self.failures)
        out.final[:] = states
        lib = self.library()
        alive, routes, k = np.arange(len(states)), set(), 0
        while k < steps and alive.size:
            stop.check()
            count = 1 if lib is None else _steps_a_call(len(alive), self.np, steps - k)
            with progress.reporting(_silent):
                if lib is None:
                    part = self.walk(step_params(alive, k), out.final[alive], 1,
                                     converge_tol=0.0, period_tol=0.0, threads=threads,
                                     tolerance=tolerance)  # fmt: skip
                else:
                    rows = self._step_rows(step_params, alive, k, count)
                    part = self._walk_steps(lib, rows, out.final[alive], tolerance, threads)
            stop.check()
            k += count
            progress.report(k, steps)
            routes.add(part.route)
            walked = part.outcome == WALKED
            out.final[alive] = part.final
            out.steps[alive] += part.steps
            out.outcome[alive[~walked]] = part.outcome[~walked]
            out.aux[alive[~walked]] = part.aux[~walked]
            alive = alive[walked]
        out.route = "; ".join(sorted(routes - {"compiled"})) or "compiled"
        return out

    def _step_rows(self, step_params, walks: np.ndarray, first: int, count: int) -> np.ndarray:
        """The parameter rows of steps ``first .. first + count - 1`` of ``walks``: (walks,
        steps, parameters), C-contiguous (see :meth:`walk_varying`)."""
        of_steps = getattr(step_params, "of_steps", None)
        if of_steps is not None:
            rows = np.asarray(of_steps(walks, first, count), dtype=float)
        else:
            rows = np.stack([np.asarray(step_params(walks, k), dtype=float).reshape(-1, self.np)
                             for k in range(first, first + count)], axis=1)  # fmt: skip
        if rows.shape != (len(walks), count, self.np):
            raise VswInputError(f"the parameter rows of {count} steps of {len(walks)} walks "
                                f"must have shape {(len(walks), count, self.np)}, got "
                                f"{rows.shape}")  # fmt: skip
        return np.ascontiguousarray(rows)

    def _walk_steps(self, lib: ctypes.CDLL, rows: np.ndarray, states: np.ndarray,
                    tolerance: float, threads: int | None) -> BatchResult:  # fmt: skip
        """Each walk of ``states`` up to ``rows.shape[1]`` steps, step ``k`` on its row
        ``rows[:, k]`` (``vsw_batch_walk_steps``), in blocks of :data:`CHUNK` walks on
        threads."""
        threads = default_threads() if threads is None else threads
        n, count = len(states), rows.shape[1]
        states = np.ascontiguousarray(states)
        out = _empty_result(n, self.nx, 0, self.failures)
        opts = np.array([tolerance, tolerance, PHASE_TIME_LIMIT], dtype=float)
        fn = _bound_walk_steps(lib)

        def block(start: int) -> None:
            stop = min(start + CHUNK, n)
            fn(stop - start, rows[start:stop], states[start:stop], opts, count,
               out.outcome[start:stop], out.aux[start:stop], out.steps[start:stop],
               out.final[start:stop])  # fmt: skip

        with blas.limited(threads):
            run_blocks(block, range(0, n, CHUNK), threads)
        return out

    def step(
        self, params, states, threads: int | None = None, tolerance: float = RTOL
    ) -> BatchResult:
        """One step of the Poincaré map from each row of ``states``: ``final`` holds the
        state after it, ``kept_lengths``/``kept_durations`` its length and duration."""
        return self.walk(params, states, 1, converge_tol=0.0, period_tol=0.0, keep=1,
                         threads=threads, tolerance=tolerance)  # fmt: skip

    def step_phases(self, params: Sequence[float], state: Sequence[float]) -> StepResult:
        """One step from ``state`` with each phase visit's duration, in
        :meth:`vsw.dynamics.hybrid.HybridModel.step`'s form (``state``: the next section state;
        where the step fell or stalled, the step's start, not the state it fell in), by the compiled
        integrator at the SciPy route's tolerance: what the periodic-orbit solver takes as
        its guess of the durations and its confirmation without importing SciPy. The SciPy
        route itself when the simulator cannot be built."""
        lib = self.library()
        if lib is None:
            return self.model.step(tuple(float(v) for v in params), np.asarray(state, float))
        step = _bound_step_phases(lib)
        p, x = self._checked(params, state)
        options = np.array([RTOL, ATOL, PHASE_TIME_LIMIT])
        durations = np.zeros(len(self.model.phases) + 1)
        visits, failure, length = ctypes.c_int(0), ctypes.c_int(0), ctypes.c_double(0.0)
        code = step(p, x, options, durations, ctypes.byref(visits), ctypes.byref(failure),
                    ctypes.byref(length))  # fmt: skip
        stop.check()  # a Ctrl-C or time limit ends the integration early: not a stall
        taken = tuple(float(t) for t in durations[: visits.value])
        if code == FELL:
            return StepResult(x, self.failures[failure.value], taken)
        if code == STALLED:
            return StepResult(x, "stalled", taken)
        walked = length.value if math.isfinite(length.value) else None
        return StepResult(x, "completed", taken, walked)

    def sampled_step(self, params: Sequence[float], state: Sequence[float],
                     max_step: float) -> Trajectory:  # fmt: skip
        """One step from the section state ``state``, sampled as
        :meth:`vsw.dynamics.hybrid.HybridModel.simulate` samples it (each phase's start, each
        accepted step of the integrator, at most ``max_step`` long, and each event's point
        twice), by the compiled integrator: the same samples to rounding, the SciPy route's
        rules at its tolerance. The SciPy route itself when the simulator cannot be built."""
        if not max_step > 0:
            raise VswInputError(f"max_step must be positive, got {max_step!r}")
        lib = self.library()
        if lib is None:
            return self.model.simulate(params, np.asarray(state, float), 1, max_step=max_step)
        walk = self._sampled(lib, params, state, max_step, 1024)  # SAMPLES take about 420
        if walk.count > len(walk.t):  # again, with room for every sample
            walk = self._sampled(lib, params, state, max_step, walk.count)
        n = walk.count
        ended = ("completed" if walk.code == WALKED else self.failures[walk.failure]
                 if walk.code == FELL else "stalled")  # fmt: skip
        section = np.array([walk.start, walk.end] if walk.code == WALKED else [walk.start])
        return Trajectory(walk.t[:n], walk.x[:n], walk.phase[:n].astype(int), section, ended,
                          int(walk.code == WALKED))  # fmt: skip

    def step_events(self, params: Sequence[float], state: Sequence[float]) -> list[EventRecord]:
        """:meth:`vsw.dynamics.hybrid.HybridModel.step_events` by the compiled integrator (the
        same events, their states to rounding); the SciPy route itself when the simulator
        cannot be built."""
        lib = self.library()
        if lib is None:
            return self.model.step_events(params, np.asarray(state, float))
        walk = self._sampled(lib, params, state, math.inf, 0, events=True)
        happened = zip(walk.event, walk.event_time, walk.before, walk.after)
        return [self.model.event_record(params, self.model.events[k], *at)
                for k, *at in happened]  # fmt: skip

    def _sampled(self, lib: ctypes.CDLL, params: Sequence[float], state: Sequence[float],
                 max_step: float, capacity: int, events: bool = False) -> _SampledStep:  # fmt: skip
        """``vsw_batch_sample_step`` from ``state``, with room for ``capacity`` samples."""
        p, x = self._checked(params, state)
        walk = _SampledStep(start=x.copy(), end=x, t=np.empty(capacity),
                            x=np.empty((capacity, self.nx)),
                            phase=np.empty(capacity, dtype=np.int32))  # fmt: skip
        room = len(self.model.phases) + 1
        if events:
            walk.event, walk.event_time = np.empty(room, np.int32), np.empty(room)
            walk.before, walk.after = np.empty((room, self.nx)), np.empty((room, self.nx))
        count, failure, taken = ctypes.c_longlong(0), ctypes.c_int(0), ctypes.c_int(0)
        options = np.array([RTOL, ATOL, PHASE_TIME_LIMIT, max_step])
        walk.code = _bound_sample_step(lib)(
            p, x, options, capacity, walk.t, walk.x, walk.phase, ctypes.byref(count),
            ctypes.byref(failure), *(_address(a) for a in (walk.event, walk.event_time,
                                                          walk.before, walk.after)),
            ctypes.byref(taken),
        )  # fmt: skip
        stop.check()  # a Ctrl-C or time limit ends the integration early: not a stall
        walk.count, walk.failure = count.value, failure.value
        if events:
            k = taken.value
            walk.event, walk.event_time = walk.event[:k], walk.event_time[:k]
            walk.before, walk.after = walk.before[:k], walk.after[:k]
        return walk

    def _checked(self, params: Sequence[float], state: Sequence[float]
                 ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """``params`` and ``state`` as the contiguous arrays of one walk, their sizes checked."""
        p = np.ascontiguousarray(params, dtype=float)
        x = np.array(state, dtype=float)
        if p.shape != (self.np,) or x.shape != (self.nx,):
            raise VswInputError(f"{self.model.name}: {self.np} parameters and a state of "
                                f"{self.nx} components, got {p.shape} and {x.shape}")  # fmt: skip
        return p, x


def _silent(done: int, total: int) -> None:
    """A progress listener that draws nothing (a step's blocks inside a walk of steps)."""


def _steps_a_call(walks: int, parameters: int, steps: int) -> int:
    """Steps of :meth:`BatchSimulator.walk_varying` in its next call: :data:`STEPS_PER_CALL`,
    fewer where that many rows would pass :data:`VARYING_BYTES` or the walk's end."""
    room = VARYING_BYTES // (8 * max(1, parameters) * max(1, walks))
    return int(max(1, min(STEPS_PER_CALL, steps, room)))


def _bound_walk_steps(lib: ctypes.CDLL):
    """The library's ``vsw_batch_walk_steps`` with its argument types (bound on first use,
    as :func:`_bound_step_phases`)."""
    fn = lib.vsw_batch_walk_steps
    if fn.argtypes is None:
        dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
        i32 = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
        i64 = np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS")
        ll = ctypes.c_longlong
        fn.restype = None
        fn.argtypes = [ll, dbl, dbl, dbl, ll, i32, i32, i64, dbl]
    return fn


def _bound_step_phases(lib: ctypes.CDLL):
    """The library's ``vsw_batch_step_phases`` with its argument types (bound on first use,
    not in ``_bind``: benchmark case 15 binds libraries built from commits before it)."""
    fn = lib.vsw_batch_step_phases
    if fn.argtypes is None:
        dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
        pointer = ctypes.POINTER
        fn.restype = ctypes.c_int
        fn.argtypes = [dbl, dbl, dbl, dbl, pointer(ctypes.c_int), pointer(ctypes.c_int),
                       pointer(ctypes.c_double)]  # fmt: skip
    return fn


def _address(array: np.ndarray | None) -> int | None:
    """A C-contiguous array's data address for a ``void *`` argument; NULL for None."""
    if array is None:
        return None
    assert array.flags.c_contiguous
    return array.ctypes.data


@dataclass
class _SampledStep:
    """What ``vsw_batch_sample_step`` wrote (see :meth:`BatchSimulator._sampled`)."""

    start: np.ndarray
    end: np.ndarray  # the next section state, where the step completed
    t: np.ndarray
    x: np.ndarray
    phase: np.ndarray
    code: int = STALLED
    count: int = 0
    failure: int = 0
    event: np.ndarray | None = None
    event_time: np.ndarray | None = None
    before: np.ndarray | None = None
    after: np.ndarray | None = None


def _bound_sample_step(lib: ctypes.CDLL):
    """The library's ``vsw_batch_sample_step`` with its argument types (as
    :func:`_bound_step_phases`)."""
    fn = lib.vsw_batch_sample_step
    if fn.argtypes is None:
        dbl = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
        i32 = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
        pointer = ctypes.POINTER
        fn.restype = ctypes.c_int
        void = ctypes.c_void_p  # the events' arrays, or NULL (:func:`_address`)
        fn.argtypes = [dbl, dbl, dbl, ctypes.c_longlong, dbl, dbl, i32,
                       pointer(ctypes.c_longlong), pointer(ctypes.c_int), void, void, void,
                       void, pointer(ctypes.c_int)]  # fmt: skip
    return fn


@dataclass(frozen=True)
class Options:
    """What a walk checks (see :meth:`BatchSimulator.walk`)."""

    steps: int
    target: tuple[float, ...] | None
    converge_tol: float
    period_tol: float
    max_period: int
    keep: int
    tolerance: float = RTOL


Runner = Callable[[np.ndarray, np.ndarray, Options], "BatchResult"]
"""Runs walks elsewhere: (parameter rows, states, options) -> their BatchResult."""


def _empty_result(n: int, nx: int, keep: int, failures) -> BatchResult:
    return BatchResult(
        outcome=np.zeros(n, dtype=np.int32),
        aux=np.zeros(n, dtype=np.int32),
        steps=np.zeros(n, dtype=np.int64),
        final=np.zeros((n, nx)),
        kept_states=np.full((n, keep, nx), np.nan),
        kept_lengths=np.full((n, keep), np.nan),
        kept_durations=np.full((n, keep), np.nan),
        failures=failures,
    )


def reference_walks(model: HybridModel, params, states, options: Options) -> BatchResult:
    """The same walks through the SciPy route (:meth:`HybridModel.step`), one at a time,
    with the same rules: the fallback without a compiler, and the reference of the tests.
    Its tolerance is the SciPy route's (1e-12); a ConvergenceError of a step (more phases
    than the model has) counts as a stall, as in the C code."""
    if options.tolerance != RTOL:
        raise VswInputError(
            f"tolerance {options.tolerance:g} needs the compiled batch simulator; the SciPy "
            f"route integrates at {RTOL:g}"
        )
    states = np.asarray(states, dtype=float).reshape(-1, 2 * model.n)
    params = np.broadcast_to(
        np.asarray(params, dtype=float), (len(states), len(model.spec["parameters"]))
    )
    failures = failure_names(model)
    out = _empty_result(len(states), 2 * model.n, options.keep, failures)
    target = None if options.target is None else np.array(options.target)
    for i, (p, x) in enumerate(zip(params, states)):
        x = x.copy()
        code, aux, walked = WALKED, 0, 0
        history: list[np.ndarray] = []
        kept: list[tuple[np.ndarray, float, float]] = []
        if not np.all(np.isfinite(x)):
            code = STALLED
        while code == WALKED and walked < options.steps:
            history.append(x.copy())
            try:
                result = model.step(tuple(p), x)
            except ConvergenceError:
                stop.check()
                code = STALLED
                break
            if result.ended == "stalled":
                code = STALLED
                break
            if result.ended != "completed":
                code, aux = FELL, failures.index(result.ended)
                break
            x = result.state
            if not np.all(np.isfinite(x)):
                code = STALLED
                break
            walked += 1
            length = np.nan if result.step_length is None else result.step_length
            kept.append((x.copy(), length, float(sum(result.durations))))
            if target is not None and options.converge_tol > 0:
                scale = max(1.0, float(np.max(np.abs(target))))
                if np.max(np.abs(x - target)) <= options.converge_tol * scale:
                    code = CONVERGED
                    break
            if options.period_tol > 0 and options.max_period > 0:
                bound = options.period_tol * max(1.0, float(np.max(np.abs(x))))
                for k in range(2 if target is not None else 1, min(options.max_period, walked) + 1):
                    if np.max(np.abs(x - history[-k])) > bound:
                        continue
                    lags = [np.max(np.abs(x - history[-j])) for j in range(1, k)]
                    if all(lag > APART * bound for lag in lags):
                        code, aux = PERIODIC, k
                    break
        out.outcome[i], out.aux[i], out.steps[i], out.final[i] = code, aux, walked, x
        for r, (s, length, duration) in enumerate(kept[-options.keep :] if options.keep else []):
            out.kept_states[i, r] = s
            out.kept_lengths[i, r] = length
            out.kept_durations[i, r] = duration
    return out


_SIMULATORS: dict[str, BatchSimulator] = {}
_SIMULATORS_LOCK = threading.Lock()


def simulator(model: HybridModel) -> BatchSimulator:
    """The batch simulator of ``model`` (one per model and process)."""
    with _SIMULATORS_LOCK:
        if model.name not in _SIMULATORS:
            _SIMULATORS[model.name] = BatchSimulator(model)
        return _SIMULATORS[model.name]
