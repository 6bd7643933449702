"""Blockwise evaluation returns exactly what one whole-array call returns."""

import numpy as np

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
