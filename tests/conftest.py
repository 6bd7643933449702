"""Shared fixtures: seeded random valid parameter sets of the ILE model, and the
derivation of every model done once per test run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

# The derivations the tests run in process use sympy's cache as `python -m derive` does
# (derive/__main__.py says why); set before anything imports sympy.
os.environ.setdefault("SYMPY_CACHE_SIZE", "20000")

import numpy as np
import pytest

from generated.ile.params import PARAMETERS
from vsw.models import keys, load
from vsw.models.ile.params import random_parameters

PARAMS = {p.name: p for p in PARAMETERS}


def passive_keys() -> list[str]:
    """The models with passive gaits: every one but those that walk only powered (the
    point-mass biped, whose leg force holds it up; tests/test_point_mass_biped.py)."""
    return [k for k in keys() if not load(k).spec.get("powered_only")]


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


ROOT = Path(__file__).resolve().parent.parent
DERIVATION_HASH_SEED = "4242"
"""The one full derivation of a test run runs with this hash seed, not the developer's
random one that wrote generated/: equal files are also the seed independence test."""


@pytest.fixture(scope="session")
def rendered_tree(tmp_path_factory) -> dict[str, str]:
    """Every file ``python -m derive`` writes, derived once per test run (in a subprocess
    with PYTHONHASHSEED=4242); the tests that need the derivation's output use this."""
    out = tmp_path_factory.mktemp("derived") / "tree.json"
    code = (
        "import json, sys; from derive.__main__ import render_all; "
        "open(sys.argv[1], 'w').write(json.dumps(render_all()))"
    )
    env = {**os.environ, "PYTHONHASHSEED": DERIVATION_HASH_SEED}
    subprocess.run([sys.executable, "-c", code, str(out)], cwd=ROOT, env=env, check=True)
    return json.loads(out.read_text())


@pytest.fixture(scope="session")
def ile_derivation():
    """The ILE's Derivation (sympy objects), derived once per test run for the tests that
    check the derivation itself in process (the suite derives each model once, issue 24)."""
    from derive.models import ile

    return ile.derive()


_RENDERED: dict[str, str] = {}


def cached_render_model(name: str) -> dict[str, str]:
    """One model's files from the test run's derivation (a module-level function: the
    derive command's worker processes get it by name)."""
    return {p: t for p, t in _RENDERED.items() if p.startswith(f"{name}/")}


@pytest.fixture
def cached_derivation(rendered_tree, monkeypatch):
    """``derive.__main__`` with each model's rendering taken from :func:`rendered_tree`:
    the command's own machinery (comparison, writing, --model) without deriving again."""
    import derive.__main__ as derive_main

    _RENDERED.update(rendered_tree)
    monkeypatch.setattr(derive_main, "_render_model", cached_render_model)
    return rendered_tree


@pytest.fixture(autouse=True)
def signal_handlers_restored():
    """No test leaves a signal handler or the interval timer behind (vsw.stop installs
    both while a command runs and must restore them)."""
    import signal

    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGALRM, signal.SIGTERM)}
    yield
    after = {s: signal.getsignal(s) for s in before}
    changed = {s.name: (before[s], after[s]) for s in before if after[s] is not before[s]}
    for s, handler in before.items():
        signal.signal(s, handler)
    timer = signal.getitimer(signal.ITIMER_REAL)
    signal.setitimer(signal.ITIMER_REAL, 0)
    assert not changed, f"signal handlers left changed: {changed}"
    assert timer == (0.0, 0.0), f"interval timer left running: {timer}"
