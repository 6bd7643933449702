"""The simulation's right-hand side and event functions are called on Python floats
(``vsw.dynamics.hybrid._on_floats``): they must give the bits numpy's scalars give, and
numpy's inf or NaN where Python's arithmetic would raise."""

from __future__ import annotations

import numpy as np
import pytest

from vsw import models
from vsw.dynamics.hybrid import HybridModel, _on_floats

HYBRID = [k for k in models.keys() if isinstance(models.load(k), HybridModel)]


def _functions(model: HybridModel) -> list[str]:
    names = [f"{phase['name']}_accelerations" for phase in model.phases]
    names += [f"event_{event['name']}_guard" for event in model.events]
    names += [f for phase in model.phases for _, f, _ in phase["failures"]]
    return names


@pytest.mark.parametrize("key", HYBRID)
def test_python_floats_give_numpys_bits(key):
    model = models.load(key)
    params = tuple(np.float64(p.default) for p in model.parameter_table)
    rng = np.random.default_rng(7)
    states = rng.uniform(-2.0, 2.0, (300, 2 * model.n))
    for name in _functions(model):
        function = model.function(name)
        on_floats = _on_floats(function, params)
        with np.errstate(all="ignore"):
            for x in states:
                expected = np.asarray(function(*params, *x), dtype=float)
                got = np.asarray(on_floats(x), dtype=float)
                assert np.array_equal(got, expected, equal_nan=True), (name, x)


def test_a_division_by_zero_gives_numpys_inf_not_an_error():
    def ratio(a, x, y):
        return a / x, y**400

    call = _on_floats(ratio, (1.0,))
    with np.errstate(all="ignore"):
        quotient, power = call(np.array([0.0, 1e300]))
    assert quotient == np.inf and power == np.inf
    assert call(np.array([2.0, 1.0])) == (0.5, 1.0)
