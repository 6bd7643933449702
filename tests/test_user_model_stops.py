"""A model file of the user's is derived in a subprocess while the command line is parsed:
that subprocess runs under the run-time limit, ends with Ctrl-C, and does not outlive the
``vsw`` that started it. The model file here never finishes its import (``while True``)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="needs /proc")


def _derivations_of(path: Path) -> list[int]:
    """Processes deriving the model file ``path`` (found by their command line)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            argv = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"derive" in argv and str(path).encode() in argv:
            found.append(int(entry.name))
    return found


def _gone(path: Path, within: float) -> bool:
    deadline = time.monotonic() + within
    while _derivations_of(path):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


@pytest.fixture
def looping(tmp_path):
    path = tmp_path / "looping_walker.py"
    path.write_text("while True:\n    pass\n")
    env = {**os.environ, "VSW_MODELS_DIR": str(tmp_path / "models")}
    yield path, env
    for pid in _derivations_of(path):  # a failing test leaves none behind
        os.kill(pid, signal.SIGKILL)


def _start(path: Path, env: dict[str, str]) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "vsw", "analyze", "--model", str(path)],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip


def _deriving(process: subprocess.Popen, path: Path) -> None:
    deadline = time.monotonic() + 20
    while not _derivations_of(path):
        assert process.poll() is None and time.monotonic() < deadline, "no derivation started"
        time.sleep(0.05)


def test_the_limit_stops_a_model_file_that_never_finishes_deriving(looping):
    path, env = looping
    env["VSW_MAX_SECONDS"] = "3"
    started = time.monotonic()
    process = _start(path, env)
    out, err = process.communicate(timeout=30)
    elapsed = time.monotonic() - started
    assert process.returncode == 2 and out == "", err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith("vsw: error: stopped after 3") and "VSW_MAX_SECONDS" in last, err
    assert elapsed < 3 + 2 + 1.5, elapsed  # the limit, its 2 s, and the start-up
    assert _gone(path, 1.0)


def test_a_terminated_vsw_takes_its_derivation_with_it(looping):
    path, env = looping
    process = _start(path, env)
    _deriving(process, path)
    process.terminate()
    process.communicate(timeout=10)
    assert _gone(path, 2.0), "the derivation outlived vsw"


def test_ctrl_c_while_deriving_is_130_and_one_line(looping):
    path, env = looping
    process = _start(path, env)
    _deriving(process, path)
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=10)
    assert process.returncode in (130, -signal.SIGINT), err
    assert out == "" and "Traceback" not in err
    assert err.strip().splitlines()[-1] == "vsw: interrupted"
    assert _gone(path, 2.0)
