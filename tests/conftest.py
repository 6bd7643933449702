"""Shared fixtures: seeded random valid parameter sets of the ILE model, and the
derivation of every model done once per test run."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

# The derivations the tests run in process use sympy's cache as `python -m derive` does
# (derive/__main__.py says why); set before anything imports sympy.
os.environ.setdefault("SYMPY_CACHE_SIZE", "20000")

import numpy as np
import pytest

from generated.ile.params import PARAMETERS
from vsw.dynamics.compiled import exclusive_lock
from vsw.dynamics.hybrid import Orbit
from vsw.gaits.search import pick
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


def run_directory(tmp_path_factory) -> Path:
    """A directory of this test run that every pytest-xdist worker sees: the parent of the
    workers' own temporary directories (each worker is a session of its own)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@contextlib.contextmanager
def run_lock(path: Path, locks: Path) -> Iterator[None]:
    """Held by one worker of the test run at a time: the first makes ``path``, the others
    wait and read it. The lock file lies in ``locks``, named by a hash of the path (not
    beside it: tests count the files of a cache)."""
    locks.mkdir(parents=True, exist_ok=True)
    name = hashlib.sha256(str(path).encode()).hexdigest()[:24]
    with exclusive_lock(locks / name):
        yield


@pytest.fixture(scope="session", autouse=True)
def private_kernel_cache(tmp_path_factory):
    """Compiled kernels and kept gait searches go to a temporary cache, not the user's
    ~/.cache/vsw (also for the subprocesses tests start, which inherit the environment);
    one cache for every worker of the run, so a kernel is compiled and a search made once
    (vsw locks its builds; :func:`searches_made_once` its searches)."""
    if os.environ.get("VSW_CACHE_DIR"):
        yield
        return
    cache = run_directory(tmp_path_factory) / "vsw_cache"
    cache.mkdir(exist_ok=True)
    os.environ["VSW_CACHE_DIR"] = str(cache)
    try:
        yield
    finally:
        os.environ.pop("VSW_CACHE_DIR", None)


@pytest.fixture(scope="session", autouse=True)
def searches_made_once(private_kernel_cache, tmp_path_factory):
    """A gait search that another worker is making is waited for and then read from the
    shared cache instead of made again: vsw's cache publishes a search whole but does not
    stop two processes from both making it. The lock is keyed by the search's own file, so
    a test's private cache (VSW_CACHE_DIR=tmp_path) or VSW_SEARCH_CACHE=0 is as without it."""
    import vsw.gaits.search as gaits
    from vsw.gaits.search_cache import cache_file

    search = gaits.search
    locks = run_directory(tmp_path_factory) / "locks"

    def search_once(model, params, *, box=None, cells=None):
        sim = gaits.simulator(model)
        checked = gaits.check_box(model, box)
        values = tuple(float(v) for v in params)
        path = cache_file(model, sim, values, checked, cells) if sim.library() else None
        if path is None:
            return search(model, params, box=box, cells=cells)
        with run_lock(path, locks):
            return search(model, params, box=box, cells=cells)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(gaits, "search", search_once)
        yield


GAITS_PATH = Path(__file__).resolve().parent / "data" / "gaits.json"
"""Every passive model's gaits at its defaults, as the search finds them (written by
tests/data/make_gaits.py; compared with a new search in tests/test_gaits.py's slow tier)."""


def _orbit(record: dict) -> Orbit:
    """An :meth:`Orbit.to_dict` record read back (JSON keeps every float exactly)."""
    return Orbit(
        state={k: float(v) for k, v in record["state"].items()},
        durations=tuple(record["phase_durations"]),
        period=record["period"],
        eigenvalues=tuple(complex(re, im) for re, im in record["eigenvalues"]),
        step_length=record["step_length"],
        residual=record["residual"],
    )


def _confirm(model, params: tuple[float, ...], orbit: Orbit, newton: bool) -> None:
    """Fails unless ``orbit`` is a gait of ``model`` at ``params`` as the code is now: a
    compiled step from it comes back (within 1e-9 of max(1, |state|) times max(1,
    |eigenvalue|), the search's own test of a gait) through the same phases, in the same
    durations and step length; with ``newton``, also Newton on the step map converges
    next to it with the spectrum kept."""
    from vsw.dynamics.batch import simulator
    from vsw.dynamics.step_map import fixed_point

    state = np.array(list(orbit.state.values()))
    scale = max(1.0, float(np.max(np.abs(state))))
    again = f"{model.name}: regenerate {GAITS_PATH.name} (python tests/data/make_gaits.py)"
    sim = simulator(model)
    step = sim.step_phases(params, state)
    assert step.ended == "completed", f"{again}: a step from a kept gait ends {step.ended}"
    gap = float(np.max(np.abs(step.state - state)))
    assert gap <= 1e-9 * scale * max(1.0, orbit.max_abs_eigenvalue), f"{again}: {gap:.3g} off"
    assert np.allclose(step.durations, orbit.durations, rtol=0, atol=1e-7 * orbit.period), again
    if orbit.step_length is not None:
        assert abs(step.step_length - orbit.step_length) <= 1e-9 * max(1.0, orbit.step_length)
    if newton:
        found, jacobian = fixed_point(sim, params, state)
        assert np.max(np.abs(found - state)) <= 1e-9 * scale, again
        largest = max(abs(np.linalg.eigvals(jacobian)))
        assert largest == pytest.approx(orbit.max_abs_eigenvalue, rel=1e-4), again


_COMMITTED: dict[str, tuple[object, tuple[float, ...], list[Orbit]]] = {}


def committed_gaits(key: str) -> tuple[object, tuple[float, ...], list[Orbit]] | None:
    """``(model, default parameters, gaits)`` of a passive model from :data:`GAITS_PATH`,
    each gait confirmed by a step and the one the commands walk from
    (:func:`vsw.gaits.search.pick`) by a Newton solve too: what ``model.fixed_points`` returns at
    the defaults, for a fraction of a search. None for a model not in the file yet
    (tests/test_gaits.py's slow tier asks for it)."""
    if key in _COMMITTED:
        return _COMMITTED[key]
    record = json.loads(GAITS_PATH.read_text())["models"].get(key)
    if record is None:
        return None
    model = load(key)
    params = model.parameters()
    names = [p.name for p in model.parameter_table]
    assert record["parameters"] == dict(zip(names, params)), (
        f"{key}: its default parameters changed: python tests/data/make_gaits.py"
    )
    orbits = [_orbit(r) for r in record["gaits"]]
    picked = pick(orbits)
    for orbit in orbits:
        _confirm(model, params, orbit, newton=orbit is picked)
    _COMMITTED[key] = (model, params, orbits)
    return _COMMITTED[key]


def gait_start(key: str) -> tuple[object, tuple[float, ...], np.ndarray]:
    """``(model, default parameters, start)``: the state ``model.start(params)`` walks from
    (the first stable gait, else the first), from :func:`committed_gaits`, or from the
    search for a model not in the file."""
    committed = committed_gaits(key)
    if committed is None:
        model = load(key)
        params = model.parameters()
        return model, params, model.start(params, None, None).state
    model, params, orbits = committed
    return model, params, np.array(list(pick(orbits).state.values()))


ROOT = Path(__file__).resolve().parent.parent
DERIVATION_HASH_SEED = "4242"
"""The one full derivation of a test run runs with this hash seed, not the developer's
random one that wrote generated/: equal files are also the seed independence test."""


@pytest.fixture(scope="session")
def rendered_tree(tmp_path_factory) -> dict[str, str]:
    """Every file ``python -m derive`` writes, derived once per test run (in a subprocess
    with PYTHONHASHSEED=4242, by the first worker that needs it); the tests that need the
    derivation's output use this."""
    out = run_directory(tmp_path_factory) / "derived" / "tree.json"
    code = (
        "import json, os, sys; from derive.__main__ import render_all; "
        "open(sys.argv[1] + '.part', 'w').write(json.dumps(render_all())); "
        "os.replace(sys.argv[1] + '.part', sys.argv[1])"
    )
    env = {**os.environ, "PYTHONHASHSEED": DERIVATION_HASH_SEED}
    with run_lock(out, out.parent):  # one derivation for all the run's workers
        if not out.exists():
            subprocess.run([sys.executable, "-c", code, str(out)], cwd=ROOT, env=env, check=True)
    return json.loads(out.read_text())


@pytest.fixture(scope="session")
def ile_derivation():
    """The ILE's Derivation (sympy objects), derived once per test run for the tests that
    check the derivation itself in process (the suite derives each model once)."""
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
    """No test leaves a signal handler or the interval timer behind (vsw.runtime.stop installs
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


@pytest.hookimpl(tryfirst=True)  # before xdist's own, which reads the groups
def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist (``--dist loadgroup``), the tests of a module that share one of
    its module-scoped fixtures run on one worker: each worker is a session of its own and
    would otherwise compute the fixture (an audit, a walk, a search) again. The tests of
    the run's one derivation (:func:`rendered_tree`, with their modules' shared groups) run
    on one worker too: it is made behind a lock, and a second worker that needed it would
    wait the whole derivation idle."""
    groups: dict[pytest.Item, str] = {}
    joined = set()  # modules whose shared fixture a test of the derivation takes too
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        if info is None or item.get_closest_marker("xdist_group"):
            continue
        shared = any(
            definition.scope == "module"
            for name in info.names_closure
            for definition in info.name2fixturedefs.get(name, ())
        )
        if "rendered_tree" in info.names_closure:
            groups[item] = "rendered_tree"
            if shared:
                joined.add(item.module.__name__)
        elif shared:
            groups[item] = item.module.__name__
    for item, group in groups.items():
        item.add_marker(pytest.mark.xdist_group("rendered_tree" if group in joined else group))


def chromium_path() -> str | None:
    """The system's Chromium (Debian's package), or None."""
    found = map(shutil.which, ("chromium", "chromium-browser", "google-chrome"))
    return next(filter(None, found), None)


@contextlib.contextmanager
def headless_page(url: str, width: int, height: int = 800) -> Iterator[tuple[object, list[str]]]:
    """A page of headless Chromium at ``url`` (``width`` x ``height`` px) and the list its
    console errors and uncaught exceptions go to; the test is skipped without playwright or
    Chromium."""
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    path = chromium_path()
    if path is None:
        pytest.skip("no Chromium found (apt-get install chromium; .ci/run tries it)")
    errors: list[str] = []
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=path, headless=True,
                                    args=["--no-sandbox", "--disable-gpu"])  # fmt: skip
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(url)
            yield page, errors
        finally:
            browser.close()
