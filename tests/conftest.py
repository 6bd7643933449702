"""Shared fixtures: seeded random valid parameter sets of the ILE model."""

from __future__ import annotations

import os

import numpy as np
import pytest

from generated.ile.params import PARAMETERS
from vsw.models.ile.params import random_parameters

PARAMS = {p.name: p for p in PARAMETERS}


def random_valid_parameters(n: int, seed: int = 0, margin: float = 1e-3) -> dict[str, np.ndarray]:
    """``n`` parameter sets drawn uniformly inside the open domain of the parameter table."""
    return random_parameters(n, seed, margin=margin)


def random_walking_parameters(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """``n`` parameter sets at which every physical existence condition holds."""
    return random_parameters(n, seed, walking=True)


@pytest.fixture(scope="session")
def walking_parameters() -> dict[str, np.ndarray]:
    return random_walking_parameters(200, seed=1)


@pytest.fixture(scope="session", autouse=True)
def private_kernel_cache(tmp_path_factory):
    """Compiled kernels go to a temporary cache, not the user's ~/.cache/vsw (also for the
    subprocesses tests start, which inherit the environment)."""
    if os.environ.get("VSW_CACHE_DIR"):
        yield
        return
    os.environ["VSW_CACHE_DIR"] = str(tmp_path_factory.mktemp("vsw_cache"))
    try:
        yield
    finally:
        os.environ.pop("VSW_CACHE_DIR", None)
