"""A killed ``python -m derive`` leaves no worker behind.

The derivation runs its models in forked worker processes. Killing the parent (SIGKILL,
or SIGTERM as ``timeout`` sends, or Ctrl-C) must not leave workers deriving on and
holding the caller's stdout and stderr: within a second of the parent's end no process
of the run is left and its output pipe is closed.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.skipif(
    not Path("/proc").is_dir() or (len(os.sched_getaffinity(0)) < 2),
    reason="needs /proc and two cores (one worker runs serially in the parent)",
)


def _children(pid: int) -> list[int]:
    children: list[int] = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            children += [int(c) for c in (task / "children").read_text().split()]
        except OSError:
            pass
    return children


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"  # a zombie has ended; only its parent's wait is missing


@pytest.mark.parametrize("signum", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_killed_derive_leaves_no_worker(tmp_path, signum):
    process = subprocess.Popen(
        [sys.executable, "-m", "derive", "--check", "--force"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 60
        workers: list[int] = []
        while len(workers) < 2 and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.05)
            workers = _children(process.pid)
        assert len(workers) >= 2, "the derivation never started its workers"
        time.sleep(0.5)  # the workers are deriving now
        process.send_signal(signum)
        process.wait(timeout=10)
        time.sleep(1.0)
        left = [pid for pid in workers if _alive(pid)]
        assert left == [], f"workers {left} still running a second after {signum.name}"
        # Nothing holds the pipes any more: reading them ends.
        _, err = process.communicate(timeout=5)
        if signum == signal.SIGINT:
            assert process.returncode == 130
            assert err.decode().strip().splitlines()[-1] == "python -m derive: interrupted"
        elif signum == signal.SIGTERM:
            assert process.returncode == 128 + signal.SIGTERM
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
