"""Shared fixtures: seeded random valid parameter sets of the ILE model."""

from __future__ import annotations

import numpy as np
import pytest

from generated.ile_params import PARAMETERS

PARAMS = {p.name: p for p in PARAMETERS}


def random_valid_parameters(n: int, seed: int = 0, margin: float = 1e-3) -> dict[str, np.ndarray]:
    """``n`` parameter sets drawn uniformly inside the open domain of the parameter table."""
    rng = np.random.default_rng(seed)
    out = {}
    for name, p in PARAMS.items():
        width = p.upper - p.lower
        out[name] = rng.uniform(p.lower + margin * width, p.upper - margin * width, n)
    return out


def random_walking_parameters(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """``n`` parameter sets at which every physical existence condition holds."""
    import generated.ile as ile

    physical = [i for i, c in enumerate(ile.CONDITIONS) if c[4]]
    picked: dict[str, list[np.ndarray]] = {k: [] for k in PARAMS}
    count, batch_seed = 0, seed
    while count < n:
        draw = random_valid_parameters(4 * n, batch_seed)
        batch_seed += 1000
        with np.errstate(all="ignore"):
            margins = ile.condition_margins(draw["beta"], draw["theta_II"], draw["phi0"])
        ok = np.ones(4 * n, dtype=bool)
        for i in physical:
            m = np.broadcast_to(margins[i], ok.shape)
            ok &= (m > 1e-6) if ile.CONDITIONS[i][2] else (m >= 1e-6)
        for k in PARAMS:
            picked[k].append(draw[k][ok])
        count += int(ok.sum())
    return {k: np.concatenate(v)[:n] for k, v in picked.items()}


@pytest.fixture(scope="session")
def walking_parameters() -> dict[str, np.ndarray]:
    return random_walking_parameters(200, seed=1)
