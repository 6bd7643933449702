"""vsw.runtime.forked.split_map: the loop's results, in order, on several processes; a
failing child's items run again in the caller; a stop in the caller ends the children."""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path

import pytest

from vsw.runtime.forked import split_map

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forks on Linux only")


def _square_and_pid(x):
    time.sleep(0.05)
    return x * x, os.getpid()


@pytest.mark.parametrize("workers", [1, 2, 3, 8])
@pytest.mark.parametrize("count", [0, 1, 2, 7])
def test_the_results_are_the_loops_in_order(workers, count):
    got = split_map(_square_and_pid, list(range(count)), workers)
    assert [value for value, _ in got] == [x * x for x in range(count)]


@linux
def test_the_work_is_shared_among_processes():
    parent = os.getpid()
    pids = {pid for _, pid in split_map(_square_and_pid, list(range(8)), 2)}
    assert parent in pids and len(pids) == 2


def _inner_pids(x):
    return x, os.getpid(), {pid for _, pid in split_map(_square_and_pid, [1, 2, 3], 2)}


@linux
def test_an_item_that_splits_again_runs_its_items_in_its_own_process():
    # A child's own children would outlive a stop: inside a child the inner call is a loop
    # (the caller's items may still fork, the caller being no child).
    got = split_map(_inner_pids, list(range(4)), 2)
    assert [x for x, _, _ in got] == list(range(4))
    parent = os.getpid()
    for _, pid, inner in got:
        if pid != parent:
            assert inner == {pid}
    assert any(pid != parent for _, pid, _ in got)


@linux
def test_a_crashing_childs_items_run_in_the_caller():
    parent = os.getpid()

    def crash_in_child(x):
        time.sleep(0.05)
        if os.getpid() != parent:
            os._exit(3)  # as a segfault would end it: no result written
        return x + 1

    assert split_map(crash_in_child, list(range(6)), 2) == [x + 1 for x in range(6)]


@linux
def test_an_error_in_the_caller_propagates_and_no_child_is_left():
    parent = os.getpid()

    def fail_in_parent(x):
        if os.getpid() == parent:
            raise KeyboardInterrupt  # as a Ctrl-C recorded by vsw.runtime.stop raises
        time.sleep(5)  # a child still working when the caller stops
        return x

    began = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        split_map(fail_in_parent, list(range(4)), 2)
    assert time.monotonic() - began < 4  # the child was killed and reaped, not waited for


@linux
def test_children_that_delivered_are_reaped_by_a_later_call():
    """split_map does not wait for a child's exit once it has its results; the next call
    reaps it, so calls leave no trail of zombies."""
    children = Path(f"/proc/self/task/{os.getpid()}/children")
    if not children.exists():
        pytest.skip("no /proc children list here")
    before = set(children.read_text().split())  # other tests' processes, if any
    for _ in range(8):
        assert split_map(lambda x: x * 2, [1, 2, 3, 4], 2) == [2, 4, 6, 8]
    left = None
    for _ in range(100):  # until every child has exited (a loaded machine takes longer)
        assert split_map(lambda x: x * 2, [1], 2) == [2]  # one item: no child, a reap
        left = set(children.read_text().split()) - before
        if not left:
            break
        time.sleep(0.05)
    assert left == set(), {pid: _process(pid) for pid in left}


def _process(pid: str) -> str:
    """A child's state and command line, to say what was left."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
        command = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return "gone"
    return f"{state} {command[:200]}"


@linux
def test_only_the_main_thread_reaps(monkeypatch):
    """A call from another thread (a loop) leaves the delivered children to the main
    thread: two reapers of one child would both take it off the list."""
    assert split_map(lambda x: x, [1, 2], 2) == [1, 2]  # a child delivered, not waited for
    calls = []
    waitpid = os.waitpid
    monkeypatch.setattr(os, "waitpid", lambda *a: calls.append(a) or waitpid(*a))
    other = threading.Thread(target=split_map, args=(lambda x: x, [1, 2], 2))
    other.start()
    other.join()
    assert calls == []
    split_map(lambda x: x, [1], 2)
    assert calls  # the main thread reaps


def test_off_the_main_thread_it_is_a_loop():
    out = []
    thread = threading.Thread(target=lambda: out.extend(split_map(_square_and_pid, [1, 2, 3], 4)))
    thread.start()
    thread.join()
    assert {pid for _, pid in out} == {os.getpid()}
