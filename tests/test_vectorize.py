"""Blockwise evaluation returns exactly what one whole-array call returns."""

import warnings

import numpy as np
import pytest

import generated.ile as ile
from tests.conftest import random_valid_parameters
from vsw.runtime.vectorize import chunked


def test_chunked_equals_direct_for_arrays_and_tuples():
    p = random_valid_parameters(50_000, seed=2)
    args = (p["beta"], p["theta_II"], p["phi0"])
    with np.errstate(all="ignore"):
        direct = ile.condition_margins(*args)
        blocks = chunked(ile.condition_margins, *args, chunk=4096)
        assert len(blocks) == len(direct)
        for d, b in zip(direct, blocks):
            np.testing.assert_array_equal(np.broadcast_to(d, b.shape), b)
        np.testing.assert_array_equal(chunked(ile.q_fixed, *args, chunk=1000), ile.q_fixed(*args))


def test_chunked_keeps_the_broadcast_shape():
    out = chunked(ile.q_fixed, np.linspace(0.75, 0.95, 7)[:, None], 0.0, np.full(5, 0.8))
    assert out.shape == (7, 5)
    direct = ile.q_fixed(np.linspace(0.75, 0.95, 7)[:, None], 0.0, 0.8)
    np.testing.assert_allclose(out, np.broadcast_to(direct, out.shape), rtol=1e-14)


def test_chunked_writes_into_given_outputs_and_checks_them():
    rng = np.random.default_rng(3)
    args = (rng.uniform(0.5, 0.95, 5000), rng.uniform(-0.3, 0.3, 5000), rng.uniform(0.3, 1.2, 5000))
    with np.errstate(all="ignore"):
        expected = ile.fixed_point_conditions(*args)
        out = tuple(np.empty(5000) for _ in expected)
        for threads in (1, 2):
            for chunk in (1000, 8000):
                got = chunked(
                    ile.fixed_point_conditions, *args, chunk=chunk, threads=threads, out=out
                )
                assert all(g is o for g, o in zip(got, out))
                for g, e in zip(got, expected):
                    np.testing.assert_array_equal(g, e)
    with pytest.raises(ValueError, match="C-contiguous float arrays of shape"):
        chunked(ile.fixed_point_conditions, *args, out=out[:3])


def test_thread_count_does_not_change_results():
    rng = np.random.default_rng(4)
    args = (rng.uniform(0.5, 0.95, 70000), rng.uniform(-0.3, 0.3, 70000), 0.8)
    with np.errstate(all="ignore"):
        one = chunked(ile.condition_margins, *args, threads=1)
        two = chunked(ile.condition_margins, *args, threads=2)
    for a, b in zip(one, two):
        np.testing.assert_array_equal(a, b)


def test_vsw_threads_setting_is_checked(monkeypatch):
    from vsw.runtime.threads import default_threads

    monkeypatch.setenv("VSW_THREADS", "3")
    assert default_threads() == 3
    monkeypatch.setenv("VSW_THREADS", "zero")
    with pytest.raises(ValueError, match="VSW_THREADS must be a positive integer"):
        default_threads()


def test_nested_blockwise_evaluation_runs_and_does_not_deadlock():
    x = np.linspace(0.0, 1.0, 40000)

    def outer(block):
        return chunked(np.sin, block, chunk=1000, threads=2) + 1.0

    got = chunked(outer, x, chunk=8000, threads=2)
    np.testing.assert_array_equal(got, np.sin(x) + 1.0)


def test_errstate_of_the_caller_applies_in_worker_threads():
    x = np.full(50000, -1.0)
    for threads in (1, 2):
        with np.errstate(invalid="raise"), pytest.raises(FloatingPointError):
            chunked(np.sqrt, x, chunk=1000, threads=threads)
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("error")
            assert np.isnan(chunked(np.sqrt, x, chunk=1000, threads=threads)).all()


def test_first_block_error_reaches_the_caller_after_all_blocks_stopped():
    import time

    x = np.arange(20000.0)
    out = np.zeros(20000)

    def fn(block):
        if block[0] == 5000:
            raise RuntimeError("block failed")
        time.sleep(0.002)
        return block

    with pytest.raises(RuntimeError, match="block failed"):
        chunked(fn, x, chunk=1000, threads=2, out=out)
    snapshot = out.copy()
    time.sleep(0.1)
    np.testing.assert_array_equal(out, snapshot)  # no block writes after the raise


def test_callers_on_several_threads_with_different_thread_counts():
    from concurrent.futures import ThreadPoolExecutor

    x = np.linspace(0.0, 1.0, 30000)
    with ThreadPoolExecutor(4) as callers:
        results = list(
            callers.map(lambda k: chunked(np.cos, x, chunk=1000, threads=2 + k % 3), range(12))
        )
    for r in results:
        np.testing.assert_array_equal(r, np.cos(x))


def test_blockwise_evaluation_works_in_a_forked_child():
    import multiprocessing

    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork on this platform")
    x = np.linspace(0.0, 1.0, 30000)
    chunked(np.cos, x, chunk=1000, threads=2)  # the parent has live pool threads
    with multiprocessing.get_context("fork").Pool(1) as pool:
        result = pool.apply_async(_child_sum, (x,))
        assert result.get(timeout=60) == pytest.approx(float(np.cos(x).sum()))


def _child_sum(x):
    return float(chunked(np.cos, x, chunk=1000, threads=2).sum())
