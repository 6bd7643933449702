"""Blockwise evaluation returns exactly what one whole-array call returns."""

import numpy as np
import pytest

import generated.ile as ile
from tests.conftest import random_valid_parameters
from vsw.vectorize import chunked


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
    from vsw.vectorize import default_threads

    monkeypatch.setenv("VSW_THREADS", "3")
    assert default_threads() == 3
    monkeypatch.setenv("VSW_THREADS", "zero")
    with pytest.raises(ValueError, match="VSW_THREADS must be a positive integer"):
        default_threads()
