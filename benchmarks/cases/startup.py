"""Case 7: whole processes from a cold start: `python -m derive` of every model and of each
alone, side by side with a checkout of DERIVE_BEFORE; a user's model file on first use; the
imports, a `vsw analyze` command and paper_check against `python -c pass`."""

from __future__ import annotations

import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from harness import ROOT, Row, Timing, _checkout, blas_threading, timed
from pins import DERIVE_BEFORE

from vsw.runtime.threads import default_threads

DERIVE_MODEL_LIMIT = 4.0
"""Seconds within which each model derives alone, cold (case 7)."""
DERIVE_MEDIAN_LIMIT = 3.0
"""Times the median of the other models' cold derivations within which each model derives
alone (case 7): a model far above it has a cost the engine should not have."""
USER_MODEL_SOURCE = "level_compass_gait"
"""The model case 7 copies outside the package as a user's model file with an impulse at
heelstrike, and times through ``vsw analyze --model path.py`` on first use."""


def _process_time(command: list[str], reps: int, env: dict | None = None) -> Timing:
    def run():
        subprocess.run(command, cwd=ROOT, check=True, capture_output=True, env=env)

    return timed(run, reps)


def case_startup(reps: int, include_audit: bool, every_model: bool = True) -> list[Row]:
    """Case 7: whole-process start-up times (``every_model``: also `python -m derive` of
    every model, 40 s; the quick mode, which only checks the harness, leaves it out)."""
    py = sys.executable
    rows = []
    modules = ("cli, models, gaits.search, studies.sweeps, studies.grid_basin, dynamics.batch, "
               "models.ile.analysis, "
               "models.ile.basin, models.ile.design, models.ile.plots, "
               "models.ile.simulate, models.ile.sweep")  # fmt: skip
    lazy_check = (
        f"import vsw.{modules.replace(', ', ', vsw.')}; import sys; "
        "heavy = [m for m in ('scipy', 'matplotlib', 'sympy') if m in sys.modules]; "
        "assert not heavy, heavy"
    )
    with tempfile.TemporaryDirectory() as out:
        env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
        if every_model:
            rows += case_derive(reps=2)
        cases = [
            ("import vsw", [py, "-c", "import vsw"], 0.3),
            (f"import vsw.{{{modules}}} (no scipy, matplotlib, sympy)",
             [py, "-c", lazy_check], 0.3),
            ("vsw analyze --beta 0.8 --theta-ii 0 --phi0 45 --json",
             [py, "-m", "vsw", "analyze", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45",
              "--json"], 0.6),
        ]  # fmt: skip
        if include_audit:
            cases.append(("python -m paper_check", [py, "-m", "paper_check", "--out", out], 60.0))
        baseline = _process_time([py, "-c", "pass"], reps)
        for label, command, target in cases:
            t = _process_time(command, 1 if "paper_check" in label else reps, env=env)
            row = Row("7", label, "python -c pass", t, baseline, f"<= {target} s absolute", None)
            if "paper_check" in label:
                row.note = "single run"
            row.met = t.median <= target
            rows.append(row)
    return rows


def _alternating(commands: list[tuple[list[str], Path]], reps: int,
                 envs: list[Callable[[], dict] | None] | None = None,
                 ) -> list[tuple[Timing, Timing]]:  # fmt: skip
    """Each command ``reps`` times, in turn (no warm-up: a cold derivation is the subject;
    no bytecode is written): for each, its wall time and its CPU time (user and system,
    of the process and its children), as Timings. ``envs``: extra environment per command,
    called afresh for each run (a run that must start cold gets a new cache; a variable
    given as None is removed)."""
    base = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    walls: list[list[float]] = [[] for _ in commands]
    cpus: list[list[float]] = [[] for _ in commands]
    for _ in range(reps):
        for k, (command, cwd) in enumerate(commands):
            extra = (envs or [None] * len(commands))[k]
            merged = {**base, **(extra() if extra else {})}
            env = {key: value for key, value in merged.items() if value is not None}
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            subprocess.run(command, cwd=cwd, check=True, capture_output=True, env=env)
            walls[k].append(time.perf_counter() - start)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpus[k].append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return [(Timing.of(w), Timing.of(c)) for w, c in zip(walls, cpus)]


def case_derive(reps: int, before: str = DERIVE_BEFORE) -> list[Row]:
    """Case 7's derivation: ``python -m derive``, every model of the registry and each
    model alone, cold (nothing on disk) and warm (nothing changed), this tree against
    commit ``before``'s side by side (each run of one alternating with the other's), each
    model's cold time against the median of the others'; and a user's model file with an
    impulse at heelstrike through ``vsw analyze --model path.py`` on first use."""
    from derive.registry import MODEL_NAMES

    py = sys.executable
    rows = []
    with _checkout(before) as old, tempfile.TemporaryDirectory() as out:
        new_all, old_all = f"{out}/new_all", f"{out}/old_all"
        (cold, cold_cpu), (old_cold, old_cold_cpu) = _alternating(
            [([py, "-m", "derive", "--force", "--out", new_all], ROOT),
             ([py, "-m", "derive", "--force", "--out", old_all], old)], reps)  # fmt: skip
        earlier = [name for name in MODEL_NAMES if _has_model(old, name)]
        added = [name for name in MODEL_NAMES if name not in earlier]
        extra = f"; {', '.join(added)} not at {before}: this tree derives more" if added else ""
        every = f"every model of the registry, cold ({len(MODEL_NAMES)}: {', '.join(MODEL_NAMES)})"
        rows.append(Row("7", f"python -m derive --force: {every}", f"the same at {before}",
                        cold, old_cold, "<= 10 s absolute", cold.median <= 10.0,
                        note="2 worker processes" + extra))  # fmt: skip
        rows.append(Row("7", f"python -m derive --force: {every}, CPU time (user + system)",
                        f"the same at {before}", cold_cpu, old_cold_cpu, "<= 20 s absolute",
                        cold_cpu.median <= 20.0,
                        note=f"2 worker processes; {blas_threading()}" + extra))  # fmt: skip
        ((warm, _), (old_warm, _)) = _alternating(
            [([py, "-m", "derive", "--check", "--out", new_all], ROOT),
             ([py, "-m", "derive", "--check", "--out", old_all], old)], reps)  # fmt: skip
        rows.append(Row("7", "python -m derive --check, nothing changed (warm: generated/MANIFEST)",
                        f"the same at {before}", warm, old_warm, "<= 1 s absolute",
                        warm.median <= 1.0))  # fmt: skip
        alone = {}
        for name in MODEL_NAMES:
            ours = ([py, "-m", "derive", "--model", name, "--force", "--out", f"{out}/n_{name}"],
                    ROOT)  # fmt: skip
            theirs = ([py, "-m", "derive", "--model", name, "--force", "--out", f"{out}/o_{name}"],
                      old)  # fmt: skip
            alone[name] = _alternating([ours] if name in added else [ours, theirs], reps)
        rows += _each_model_rows(alone, before)
        rows.append(_user_model_row(reps, before, old, Path(out)))
    return rows


def _each_model_rows(alone: dict[str, list[tuple[Timing, Timing]]], before: str) -> list[Row]:
    """A row per model derived alone: its cold time beside ``before``'s, and against the
    median of the other models' (a model far above it is a cost the engine should not
    have: the guard that no model escapes the measure)."""
    rows = []
    for name, timings in alone.items():
        wall = timings[0][0]
        others = [t[0][0].median for n, t in alone.items() if n != name] or [wall.median]
        median = statistics.median(others)
        peer = timings[1][0] if len(timings) > 1 else None
        rows.append(Row(
            "7", f"python -m derive --model {name}, cold (one process)",
            f"the same at {before}" if peer else f"none: not at {before}", wall, peer,
            f"<= {DERIVE_MODEL_LIMIT:g} s absolute and <= {DERIVE_MEDIAN_LIMIT:g}x the "
            "median of the others",
            wall.median <= DERIVE_MODEL_LIMIT and wall.median <= DERIVE_MEDIAN_LIMIT * median,
            note=f"{wall.median / median:.2f}x the median of the others ({median:.2f} s); "
            f"CPU {timings[0][1].median:.2f} s; {blas_threading()}",
        ))  # fmt: skip
    return rows


def _user_model_row(reps: int, before: str, old: Path, out: Path) -> Row:
    """``vsw analyze --model my_walker.py`` on first use (a fresh cache each run: the
    model derived, its library compiled, its gaits searched), the file a copy of
    USER_MODEL_SOURCE outside the package, in this tree and in ``before``'s, each with its
    own tree's copy (a model file imports what its tree's ``derive`` offers)."""
    paths = []
    for tree, name in ((ROOT, "user"), (old, "user_before")):
        folder = out / name
        folder.mkdir()
        paths.append(folder / "my_walker.py")
        shutil.copy(Path(tree) / "derive" / "models" / f"{USER_MODEL_SOURCE}.py", paths[-1])

    def fresh_cache() -> dict:
        # A models or searches directory of the caller's would make every run but the
        # first a warm one: the runs keep theirs in the fresh cache.
        return {"VSW_CACHE_DIR": tempfile.mkdtemp(dir=out), "VSW_MODELS_DIR": None,
                "VSW_SEARCH_CACHE": None}  # fmt: skip

    # Each tree's own vsw: the checkout's package first on the path.
    ours_command, old_command = ([sys.executable, "-m", "vsw", "analyze", "--model", str(p)]
                                 for p in paths)  # fmt: skip
    (ours, ours_cpu), (theirs, _) = _alternating(
        [(ours_command, ROOT), (old_command, old)], reps,
        envs=[lambda: {**fresh_cache(), "PYTHONPATH": str(ROOT)},
              lambda: {**fresh_cache(), "PYTHONPATH": str(old)}],
    )  # fmt: skip
    return Row("7", f"vsw analyze --model my_walker.py (a copy of {USER_MODEL_SOURCE}: an "
               "impulse at heelstrike), first use: derived, compiled, searched",
               f"the same at {before}", ours, theirs, "<= 8 s absolute", ours.median <= 8.0,
               note=f"CPU {ours_cpu.median:.2f} s; an empty cache each run; "
               f"{blas_threading()}, bounded by VSW_THREADS ({default_threads()}) in the "
               "command")  # fmt: skip


def _has_model(tree: Path, name: str) -> bool:
    """Whether the checkout ``tree`` has the model ``name`` (a module or a package)."""
    models = Path(tree) / "derive" / "models"
    return (models / f"{name}.py").is_file() or (models / name / "__init__.py").is_file()
