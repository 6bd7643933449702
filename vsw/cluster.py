"""The batch simulator's blocks on a Dask cluster (``vsw basin --scheduler ADDRESS`` or
``VSW_DASK_SCHEDULER``; the optional extra ``vsw[dask]``).

A study is cut into blocks of walks (:data:`BLOCK` walks each, whatever the cluster); each
block is one task that runs the same compiled simulator in the worker's process (built
into the worker's kernel cache on its first task) and returns its arrays. Each walk is
independent of the others and of its block, so the result is the local one, byte for
byte, and does not depend on the block size or on which worker ran what, as long as every
worker has a C compiler: a worker without one takes the SciPy route (same classes, last
bits and speed differ), and the result's ``route`` says so. Inside a worker the block runs
on one thread: the cluster's workers and threads are the parallelism.

Start a cluster on one machine (loopback) with::

    dask scheduler --host 127.0.0.1 --port 8786 &
    dask worker tcp://127.0.0.1:8786 --nworkers 2 --nthreads 1 &

and run a basin on it with ``vsw basin ... --scheduler tcp://127.0.0.1:8786``.
"""

from __future__ import annotations

import numpy as np

from vsw.batch import BatchResult, Options, Runner, failure_names, simulator
from vsw.errors import VswInputError
from vsw.models import load

__all__ = ["BLOCK", "check_scheduler", "runner", "walk_on_cluster"]

BLOCK = 8192
"""Walks per task: a 500 x 500 basin is 31 tasks."""


def _client(address: str):
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
    try:
        return Client(address, timeout=5, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise VswInputError(f"no Dask scheduler at {address!r}: {first}") from None


def check_scheduler(address: str) -> int:
    """The worker threads of the scheduler at ``address`` (at least 1); VswInputError (one
    line) unless it answers. Called before the work starts."""
    with _client(address) as client:
        return max(1, sum(client.nthreads().values()))


def run_block(model: str, params: np.ndarray, states: np.ndarray, options: Options) -> tuple:
    """One task: the walks of a block in this (worker) process, on one thread."""
    sim = simulator(load(model))
    result = sim.walk_here(params, states, options, threads=1)
    return (result.outcome, result.aux, result.steps, result.final, result.kept_states,
            result.kept_lengths, result.kept_durations, sim.build_error)  # fmt: skip


def walk_on_cluster(
    address: str, model: str, params: np.ndarray, states: np.ndarray, options: Options
) -> BatchResult:
    """The walks of :meth:`vsw.batch.BatchSimulator.walk` as tasks on the scheduler at
    ``address``; raises VswInputError (one line) when it cannot be reached."""
    failures = failure_names(load(model))
    n = len(states)
    if n == 0:
        raise VswInputError("no walks to run on the cluster")
    with _client(address) as client:
        futures = [
            client.submit(
                run_block,
                model,
                params[start : start + BLOCK],
                states[start : start + BLOCK],
                options,
                pure=False,
            )
            for start in range(0, n, BLOCK)
        ]
        parts = []
        for future in futures:
            outcome, aux, steps, final, states_k, lengths_k, durations_k, error = future.result()
            route = "compiled" if error is None else f"SciPy on a worker ({error})"
            parts.append(BatchResult(outcome, aux, steps, final, states_k, lengths_k,
                                     durations_k, failures, route))  # fmt: skip
    return BatchResult.concatenate(parts)


def runner(address: str, model: str) -> Runner:
    """A :data:`vsw.batch.Runner` that walks on the Dask scheduler at ``address``."""

    def run(params: np.ndarray, states: np.ndarray, options: Options) -> BatchResult:
        return walk_on_cluster(address, model, params, states, options)

    return run
