"""A Dask cluster that fails ends a basin with one line in a stated time.

A scheduler and its worker run as separate processes on loopback, as a user starts them
(``dask scheduler``, ``dask worker --no-nanny``, so that a killed worker stays dead), and
are killed under a running ``vsw basin``: no worker at all, the only worker killed, the
scheduler killed. Each must end the command with exit 2 and one line on stderr, within
the stated waits (:data:`vsw.studies.cluster.WORKER_WAIT`, shortened here to 2 s, and
:data:`vsw.studies.cluster.CONNECT_TIMEOUT`).
"""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

pytest.importorskip("distributed")

import vsw.studies.cluster
from tests.loopback import server
from vsw.cli import main

DASK = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
WORKER = [sys.executable, "-m", "distributed.cli.dask_worker"]
# A basin that runs far longer than the faults take to happen (about 100 s on one thread:
# no walk converges to 1e-15) after a gait search of 0.2 s.
BASIN = ["basin", "--model", "rimless-wheel", "--grid", "theta_dot=0.01:3:4000",
         "--steps", "5000", "--tol", "1e-15", "--json"]  # fmt: skip


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for_port(port: int, seconds: float = 30) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), 0.2):
            return
        time.sleep(0.1)
    raise AssertionError(f"nothing listens on port {port} after {seconds} s")


def _start(command: list[str]) -> subprocess.Popen:
    return subprocess.Popen(
        command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
    )


def _kill(process: subprocess.Popen) -> None:
    if process.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=10)


@pytest.fixture
def scheduler():
    """A scheduler process on loopback without workers: (address, process)."""
    port = _free_port()
    process = _start([*DASK, "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"])
    try:
        _wait_for_port(port)
        yield f"tcp://127.0.0.1:{port}", process
    finally:
        _kill(process)


def _worker(address: str) -> subprocess.Popen:
    """One worker process (no nanny: killed, it stays dead), ready when this returns."""
    import distributed

    process = _start([*WORKER, address, "--nthreads", "1", "--no-nanny", "--no-dashboard"])
    with distributed.Client(address, timeout=10, set_as_default=False) as client:
        client.wait_for_workers(1, timeout=30)
    return process


def _run(argv: list[str], guard_seconds: float = 60.0) -> tuple[int, str, str, float]:
    """The command in this process; interrupted (exit 130, failing the test) after
    ``guard_seconds`` s in case a fault goes unnoticed (the basin's estimate is above any useful
    limit)."""
    out, err = io.StringIO(), io.StringIO()
    started = time.monotonic()
    guard = threading.Timer(guard_seconds, os.kill, (os.getpid(), signal.SIGINT))
    guard.start()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(argv)
    finally:
        guard.cancel()
    return code, out.getvalue(), err.getvalue(), time.monotonic() - started


@pytest.fixture(autouse=True)
def short_waits(monkeypatch):
    monkeypatch.setattr(vsw.studies.cluster, "WORKER_WAIT", 2.0)
    monkeypatch.setenv("VSW_MAX_SECONDS", "inf")


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_scheduler_without_workers(scheduler):
    address, _ = scheduler
    code, out, err, elapsed = _run([*BASIN, "--scheduler", address])
    assert code == 2 and out == ""
    assert "has no workers (waited 2 s)" in _one_line(err)
    assert elapsed < 2 + vsw.studies.cluster.CONNECT_TIMEOUT + 5


def test_the_only_worker_killed_during_the_run(scheduler):
    address, _ = scheduler
    worker = _worker(address)
    try:
        timer = threading.Timer(3.0, _kill, (worker,))
        timer.start()
        code, out, err, elapsed = _run([*BASIN, "--scheduler", address])
        timer.join()
    finally:
        _kill(worker)
    assert code == 2 and out == ""
    line = _one_line(err)
    assert "no workers for 2 s with tasks left" in line or "KilledWorker" in line, line
    assert elapsed < 3 + 2 + 10


@pytest.mark.skipif(shutil.which("dask") is None, reason="the dask command is not installed")
def test_the_dask_command_is_what_the_docs_start():
    """The module docstring starts the cluster with ``dask scheduler``/``dask worker``."""
    done = subprocess.run(["dask", "worker", "--help"], capture_output=True, text=True)
    assert done.returncode == 0 and "--nthreads" in done.stdout


@contextlib.contextmanager
def _server(reply: bytes | None):
    """A loopback server that is no Dask scheduler (:func:`tests.loopback.server`): yields
    its tcp:// address."""
    with server(reply) as port:
        yield f"tcp://127.0.0.1:{port}"


SMALL_BASIN = ["basin", "--model", "rimless-wheel", "--grid", "theta_dot=0.01:3:10"]


def _run_vsw(argv: list[str]) -> tuple[int, str, str, float]:
    """The command as its own process: everything it writes to stderr, Dask's loggers and
    the interpreter's last words at exit included."""
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "vsw", *argv], capture_output=True, text=True,
                          timeout=60, env={**os.environ, "VSW_MAX_SECONDS": "inf"})  # fmt: skip
    return done.returncode, done.stdout, done.stderr, time.monotonic() - started


@pytest.mark.parametrize("scheme", ["tls", "wss"])
def test_a_tls_scheduler_without_certificates_is_one_line(scheme):
    started = time.monotonic()
    code, out, err, _ = _run([*SMALL_BASIN, "--scheduler", f"{scheme}://127.0.0.1:1"])
    assert code == 2 and out == ""
    assert "needs TLS certificates" in _one_line(err)
    assert time.monotonic() - started < 5


def test_a_server_that_answers_with_other_bytes_is_no_scheduler():
    """Dask reads the first bytes of a reply as a frame length: an HTTP reply asks for
    exabytes. One line, no out-of-memory claim, nothing at exit."""
    with _server(b"HTTP/1.1 400 Bad Request\r\n\r\n" * 4) as address:
        code, out, err, elapsed = _run_vsw([*SMALL_BASIN, "--scheduler", address])
    assert code == 2 and out == ""
    line = _one_line(err)
    assert "is no Dask scheduler" in line and address in line, line
    assert elapsed < 10


def test_a_server_that_accepts_and_stays_silent_is_refused_in_time(monkeypatch):
    monkeypatch.setattr(vsw.studies.cluster, "HANDSHAKE_TIMEOUT", 1.5)
    with _server(None) as address:
        code, out, err, elapsed = _run([*SMALL_BASIN, "--scheduler", address], guard_seconds=15.0)
    assert code == 2 and out == ""
    line = _one_line(err)
    assert "handshake did not complete within 1.5 s" in line and address in line, line
    assert elapsed < 1.5 + 3


@pytest.mark.parametrize(("run", "kill_after"), [(_run, 3.0), (_run_vsw, 4.0)],
                         ids=["in-process", "own-process"])  # fmt: skip
def test_a_scheduler_killed_during_the_run_is_one_line_of_stderr(scheduler, run, kill_after):
    """In this process, and as its own process so that Dask's loggers (which write to the
    process's stderr, not to a capture) would be seen."""
    address, process = scheduler
    worker = _worker(address)
    try:
        timer = threading.Timer(kill_after, _kill, (process,))
        timer.start()
        code, out, err, elapsed = run([*BASIN, "--scheduler", address])
        timer.join()
    finally:
        _kill(worker)
    assert code == 2 and out == ""
    line = _one_line(err)
    assert address in line and ("lost the Dask scheduler" in line or "Dask run" in line), line
    assert elapsed < kill_after + vsw.studies.cluster.CONNECT_TIMEOUT + 10


def test_a_worker_address_is_no_scheduler_in_one_line(scheduler):
    """A Dask server that is no scheduler (a worker) completes the handshake, then fails
    the client's constructor: one line, and no half-built client left to time out at
    exit."""
    import distributed

    address, _ = scheduler
    worker = _worker(address)
    try:
        with distributed.Client(address, timeout=10, set_as_default=False) as client:
            (worker_address,) = client.scheduler_info()["workers"]
        code, out, err, elapsed = _run_vsw([*SMALL_BASIN, "--scheduler", worker_address])
    finally:
        _kill(worker)
    assert code == 2 and out == ""
    line = _one_line(err)
    assert f"no Dask scheduler at {worker_address!r}" in line, line
    assert elapsed < 8
