"""The batch simulator's blocks on a Dask cluster (``vsw basin --scheduler ADDRESS`` or
``VSW_DASK_SCHEDULER``; the optional extra ``vsw[dask]``).

A study is cut into blocks of walks (:func:`block_size`: about :data:`TASKS_PER_THREAD`
tasks for each of the cluster's worker threads when the tasks are submitted, each of at
least :data:`BLOCK` walks but the last); each block is one task that runs the same
compiled simulator in the worker's process (built into the worker's kernel cache on its
first task) and returns its arrays. Each walk is
independent of the others and of its block, so the result is the local one, byte for
byte, and does not depend on the block size or on which worker ran what, as long as every
worker builds the library the client does (a C compiler, the same CPU features and glibc:
libmvec's sines or libm's, vsw/dynamics/csrc/lanes.h, differ in the last bits). A worker without a
compiler takes the SciPy route (same classes, last bits and speed differ), and the
result's ``route`` says so. Inside a worker the block runs
on one thread: the cluster's workers and threads are the parallelism.

Start a cluster on one machine (loopback) with::

    dask scheduler --host 127.0.0.1 --port 8786 &
    dask worker tcp://127.0.0.1:8786 --nworkers 2 --nthreads 1 &

and run a basin on it with ``vsw basin ... --scheduler tcp://127.0.0.1:8786``. Walks on
rough ground (``vsw rough --scheduler``, :func:`rough_on_cluster`) go as parts of the walks,
each walked to its end in one task: their terrain is a function of each walk's global index.

Faults are one line and exit 2, in a stated time: an address that is not a Dask address
(a scheme other than tcp, tls, ws, wss; no host or port); ``tls://`` or ``wss://`` without
TLS certificates in Dask's configuration; no scheduler at the address, or one that does
not answer within :data:`CONNECT_TIMEOUT` s; a server that answers but is no Dask
scheduler (its reply is not Dask's handshake, or it sends nothing): the connection and the
handshake are tried first on their own, bounded by :data:`HANDSHAKE_TIMEOUT` s in all,
because Dask's client bounds the connection but waits for the handshake forever, and reads
a stranger's bytes as a frame length (an allocation of exabytes); a scheduler with no
worker for :data:`WORKER_WAIT` s, at the start or after its last worker died with tasks
left; a scheduler lost during the run (seen within about :data:`CONNECT_TIMEOUT` s).
Dask's own log lines (its loggers and those of tornado and asyncio beneath it) are off
while the cluster is used. Ctrl-C and ``VSW_MAX_SECONDS`` cancel the tasks.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
import warnings
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

from vsw.dynamics.batch import BatchResult, Options, Runner, failure_names, simulator
from vsw.models import load
from vsw.runtime import progress, stop
from vsw.runtime.errors import SlowRouteWarning, VswInputError

if TYPE_CHECKING:
    from vsw.studies.rough import Terrain

__all__ = [
    "BLOCK",
    "CONNECT_TIMEOUT",
    "HANDSHAKE_TIMEOUT",
    "TASKS_PER_THREAD",
    "WORKER_WAIT",
    "block_size",
    "check_scheduler",
    "rough_block",
    "rough_on_cluster",
    "runner",
    "walk_on_cluster",
]

BLOCK = 8192
"""The fewest walks in a task (fewer only where the study is smaller): a task's own cost
(scheduling, sending its arrays) is milliseconds, a walk's microseconds."""

TASKS_PER_THREAD = 4
"""Tasks per worker thread: enough that a thread whose blocks fall quickly does not wait
idle for another's slow ones at the end, few enough that the tasks' own cost stays small.
Measured on a 500 x 500 basin of the simplest walker, two workers of one thread: 31 tasks
of 8192 walks took 1.35x the in-process time, 8 tasks of 31250 1.08x, 2 tasks 1.04x."""


def block_size(walks: int, threads: int) -> int:
    """Walks per task for ``walks`` walks on a cluster of ``threads`` worker threads."""
    return max(BLOCK, -(-walks // (TASKS_PER_THREAD * max(1, threads))))


CONNECT_TIMEOUT = 5.0
"""Seconds to reach the scheduler (and any later call to it) before giving up."""

HANDSHAKE_TIMEOUT = 10.0
"""Seconds to connect to the scheduler and complete Dask's handshake, together."""

WORKER_WAIT = 10.0
"""Seconds a study waits for a worker: at its start, when the scheduler has none, and
whenever the last one has left while tasks remain (then one line, exit 2)."""

_POLL = 0.5  # seconds between looks at the scheduler while tasks run


_QUIET_LOGGERS = ("distributed", "tornado", "asyncio")
"""Loggers silenced while the cluster is used, with every logger beneath them."""


def _silenced_loggers() -> list[logging.Logger]:
    """Every logger of :data:`_QUIET_LOGGERS` and beneath, those that exist now included:
    Dask gives some of its loggers their own level and handler, so a record of
    ``distributed.client`` is printed whatever the level of ``distributed``; disabling each
    logger stops its records where they are made."""
    names = {
        name
        for name in logging.root.manager.loggerDict
        if any(name == quiet or name.startswith(quiet + ".") for quiet in _QUIET_LOGGERS)
    }
    return [logging.getLogger(name) for name in sorted(names | set(_QUIET_LOGGERS))]


@contextlib.contextmanager
def _quiet_dask() -> Iterator[None]:
    """Dask's own logging off (a lost scheduler logs tracebacks on stderr; the user gets
    our one line), its connection timeout at :data:`CONNECT_TIMEOUT`."""
    import dask

    loggers = _silenced_loggers()
    disabled = [logger.disabled for logger in loggers]
    for logger in loggers:
        logger.disabled = True
    timeout = f"{CONNECT_TIMEOUT:g}s"
    try:
        with dask.config.set({"distributed.comm.timeouts.connect": timeout}):
            yield
    finally:
        for logger, was in zip(loggers, disabled):
            logger.disabled = was


def _connection_args(address: str, scheme: str) -> dict[str, Any]:
    """The client's security arguments from Dask's configuration; a TLS scheme without a
    certificate there is refused (Dask's client would fail with a TypeError)."""
    from distributed.security import Security

    args = Security().get_connection_args("client")
    if scheme in ("tls", "wss") and args.get("ssl_context") is None:
        raise VswInputError(
            f"--scheduler {address!r}: {scheme}:// needs TLS certificates in Dask's "
            "configuration (distributed.comm.tls.ca-file, distributed.comm.tls.client.cert "
            "and .key), and none are set; configure them, or use tcp://"
        )
    return args


def _handshake(address: str, connection_args: dict[str, Any]) -> None:
    """Connect to ``address`` and complete Dask's handshake within
    :data:`HANDSHAKE_TIMEOUT` s, or refuse in one line (module docstring)."""
    from distributed.comm import connect

    async def handshake() -> None:
        comm = await connect(address, timeout=CONNECT_TIMEOUT, **connection_args)
        await comm.close()

    async def bounded() -> None:
        await asyncio.wait_for(handshake(), HANDSHAKE_TIMEOUT)

    try:
        asyncio.run(bounded())
    except VswInputError:  # the run-time limit, from its signal
        raise
    except TimeoutError:
        raise VswInputError(
            f"no Dask scheduler answers at {address!r}: the connection was accepted but Dask's "
            f"handshake did not complete within {HANDSHAKE_TIMEOUT:g} s (another kind of server?)"
        ) from None
    except OSError as exc:
        raise VswInputError(f"no Dask scheduler at {address!r}: {_first_line(exc)}") from None
    except Exception as exc:  # a reply that is no Dask message: MemoryError, ValueError, ...
        raise VswInputError(
            f"what answers at {address!r} is no Dask scheduler: its reply is not Dask's "
            f"handshake ({type(exc).__name__})"
        ) from None


@contextlib.contextmanager
def _client(address: str) -> Iterator[Any]:
    """A client of the scheduler at ``address``, closed on exit; every failure of the
    cluster is one line (VswInputError), a stop (Ctrl-C, the limit) cancels the tasks."""
    try:
        from distributed import Client
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:
        raise VswInputError(
            "--scheduler needs Dask's distributed scheduler: pip install 'vsw[dask]'"
        ) from None
    # A malformed address fails inside Client's constructor, whose half-built object then
    # times out noisily when collected: check it first.
    try:
        scheme, location = parse_address(address, strict=True)
        host, port = parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise VswInputError(
            f"--scheduler {address!r} is not a Dask address (like tcp://127.0.0.1:8786): {exc}"
        ) from None
    if scheme not in ("tcp", "tls", "ws", "wss") or not host or not port:
        raise VswInputError(
            f"--scheduler {address!r} is not a Dask address with a host and port (like "
            "tcp://127.0.0.1:8786)"
        )
    connection_args = _connection_args(address, scheme)
    with _quiet_dask():
        _handshake(address, connection_args)
        # Made in two steps so that a constructor that fails leaves no half-built client
        # to time out noisily when it is collected (Client.__del__ closes it again).
        client = Client.__new__(Client)
        try:
            client.__init__(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except BaseException as exc:
            _discard(client)
            if isinstance(exc, VswInputError) or not isinstance(exc, Exception):
                raise  # a stop: Ctrl-C, the run-time limit
            # The scheduler went away, or what answers is another Dask server (a worker).
            raise VswInputError(f"no Dask scheduler at {address!r}: {_first_line(exc)}") from None
        try:
            yield client
        except (VswInputError, KeyboardInterrupt):
            raise
        except Exception as exc:  # whatever distributed raises when the cluster fails
            raise VswInputError(
                f"the Dask run on {address!r} failed: {type(exc).__name__}: {_first_line(exc)}"
            ) from None
        finally:
            with contextlib.suppress(Exception):
                client.close(timeout=CONNECT_TIMEOUT)


def _discard(client: Any) -> None:
    """Close a client whose constructor failed, briefly, and mark it closed whatever the
    close did, so that its finalizer has nothing left to wait for or to print."""
    with contextlib.suppress(Exception):
        client.close(timeout=1)
    with contextlib.suppress(Exception):
        client.status = "closed"


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _await_worker(client: Any, address: str, why: str) -> None:
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT)
    except TimeoutError:
        raise VswInputError(
            f"the Dask scheduler at {address!r} {why} (waited {WORKER_WAIT:g} s): start one, "
            f"e.g. dask worker {address}"
        ) from None


def _workers(client: Any) -> int:
    return len(client.scheduler_info(n_workers=-1).get("workers", {}))


def check_scheduler(address: str) -> int:
    """The worker threads of the scheduler at ``address`` (at least 1); VswInputError (one
    line) unless it answers and has a worker within :data:`WORKER_WAIT`. Called before the
    work starts."""
    with _client(address) as client:
        _await_worker(client, address, "has no workers")
        return max(1, sum(client.nthreads().values()))


def _results(client: Any, futures: list, address: str) -> list:
    """The futures' results, watching the cluster while they run: a lost scheduler, or no
    worker for :data:`WORKER_WAIT` seconds, is one line; a stop cancels the tasks."""
    without_workers_since: float | None = None
    try:
        while pending := [f for f in futures if not f.done()]:
            stop.check()
            progress.report(len(futures) - len(pending), len(futures))
            with contextlib.suppress(TimeoutError):  # a task that failed raises here
                pending[0].result(timeout=_POLL)
            if client.status != "running":
                raise VswInputError(f"lost the Dask scheduler at {address!r} during the run")
            if _workers(client) > 0:
                without_workers_since = None
            elif without_workers_since is None:
                without_workers_since = time.monotonic()
            elif time.monotonic() - without_workers_since > WORKER_WAIT:
                raise VswInputError(
                    f"the Dask scheduler at {address!r} has had no workers for "
                    f"{WORKER_WAIT:g} s with tasks left: the workers died or left; start one, "
                    f"e.g. dask worker {address}"
                )
        return [f.result() for f in futures]
    except BaseException:
        with contextlib.suppress(Exception):
            client.cancel(futures)
        raise


def run_block(model: str, params: np.ndarray, states: np.ndarray, options: Options) -> tuple:
    """One task: the walks of a block in this (worker) process, on one thread."""
    sim = simulator(load(model))
    result = sim.walk_here(params, states, options, threads=1)
    return (result.outcome, result.aux, result.steps, result.final, result.kept_states,
            result.kept_lengths, result.kept_durations, sim.build_error)  # fmt: skip


def walk_on_cluster(
    address: str, model: str, params: np.ndarray, states: np.ndarray, options: Options
) -> BatchResult:
    """The walks of :meth:`vsw.dynamics.batch.BatchSimulator.walk` as tasks on the scheduler at
    ``address``; raises VswInputError (one line) when it cannot be reached, has no worker,
    or fails during the run (module docstring)."""
    failures = failure_names(load(model))
    n = len(states)
    if n == 0:
        raise VswInputError("no walks to run on the cluster")
    with _client(address) as client:
        _await_worker(client, address, "has no workers")
        block = block_size(n, sum(client.nthreads().values()))
        futures = [
            client.submit(
                run_block,
                model,
                params[start : start + block],
                states[start : start + block],
                options,
                pure=False,
            )
            for start in range(0, n, block)
        ]
        parts = []
        for result in _results(client, futures, address):
            outcome, aux, steps, final, states_k, lengths_k, durations_k, error = result
            route = "compiled" if error is None else f"SciPy on a worker ({error})"
            if error is not None:
                warnings.warn(f"a Dask worker walked with SciPy: {error}", SlowRouteWarning,
                              stacklevel=2)  # fmt: skip
            parts.append(BatchResult(outcome, aux, steps, final, states_k, lengths_k,
                                     durations_k, failures, route))  # fmt: skip
    return BatchResult.concatenate(parts)


def runner(address: str, model: str) -> Runner:
    """A :data:`vsw.dynamics.batch.Runner` that walks on the Dask scheduler at ``address``."""

    def run(params: np.ndarray, states: np.ndarray, options: Options) -> BatchResult:
        return walk_on_cluster(address, model, params, states, options)

    return run


ROUGH_BLOCK = 64
"""The fewest walks in a task of walks on rough ground (fewer only where there are fewer):
each walks up to thousands of steps, so a task of 64 is many milliseconds of work."""


def rough_block(model: str, terrain: Terrain, states: np.ndarray, max_steps: int) -> tuple:
    """One task: walks on rough ground (their terrain's ``first_walk`` their global index)
    in this (worker) process, on one thread."""
    sim = simulator(load(model))
    result = sim.walk_varying(terrain, states, max_steps, threads=1)
    return result.outcome, result.aux, result.steps, result.final, sim.build_error


def rough_on_cluster(
    address: str, model: str, terrain: Terrain, states: np.ndarray, max_steps: int
) -> BatchResult:
    """The walks of :meth:`vsw.dynamics.batch.BatchSimulator.walk_varying` on the random terrain
    ``terrain`` (:class:`vsw.studies.rough.Terrain`, from walk 0) as tasks on the scheduler at
    ``address``, each task a part of the walks to their ends: a walk's terrain is a function
    of its global index (``first_walk``), so the result is the in-process one, byte for
    byte (module docstring)."""
    import copy

    failures = failure_names(load(model))
    n = len(states)
    if n == 0:
        raise VswInputError("no walks to run on the cluster")
    with _client(address) as client:
        _await_worker(client, address, "has no workers")
        threads = sum(client.nthreads().values())
        block = max(ROUGH_BLOCK, -(-n // (TASKS_PER_THREAD * max(1, threads))))
        futures = []
        for start in range(0, n, block):
            part = copy.copy(terrain)
            part.first_walk = terrain.first_walk + start
            futures.append(client.submit(rough_block, model, part, states[start : start + block],
                                         max_steps, pure=False))  # fmt: skip
        parts = []
        for outcome, aux, steps, final, error in _results(client, futures, address):
            if error is not None:
                warnings.warn(f"a Dask worker walked with SciPy: {error}", SlowRouteWarning,
                              stacklevel=2)  # fmt: skip
            route = "compiled" if error is None else f"SciPy on a worker ({error})"
            empty = np.zeros((len(steps), 0, final.shape[1]))
            parts.append(BatchResult(outcome, aux, steps, final, empty, empty[:, :, 0],
                                     empty[:, :, 0], failures, route))  # fmt: skip
    return BatchResult.concatenate(parts)
