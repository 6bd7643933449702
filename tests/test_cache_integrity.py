"""What the caches hand back is verified before it is used.

A kept gait search (:mod:`vsw.gaits.search`, ``$VSW_CACHE_DIR/searches/``) is sealed with the
SHA-256 of its canonical content and its own file name, its fields are validated when read,
and each kept gait is stepped once more before it is reported: a file altered by hand (its
digest recomputed or not), with fields out of range or copied under another name, is
ignored with a one-line note and the search is done again, so a reported gait is always a
gait. A cached user-model package (:mod:`vsw.models.user`) is sealed likewise: a damaged
one is derived again with a one-line note, never a traceback.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from vsw.cli import main
from vsw.gaits import search as gaits
from vsw.gaits import search_cache
from vsw.models import load, user
from vsw.runtime.errors import CacheWarning, VswInputError

pytest.importorskip("casadi")

ROOT = Path(__file__).resolve().parent.parent

ANALYZE = ["analyze", "--model", "compass-gait", "--param", "gamma=0.0333", "--json"]


def reseal(data: dict) -> dict:
    """``data`` with its digest made to match again, as a careful forger would (only where
    the file carries one: a format without a digest is left as it is)."""
    if "sha256" in data:
        content = {k: v for k, v in data.items() if k != "sha256"}
        text = json.dumps(content, sort_keys=True, separators=(",", ":"))
        data = {**data, "sha256": hashlib.sha256(text.encode()).hexdigest()}
    return data


def run(argv: list[str]) -> tuple[int, str, str]:
    """``vsw argv`` in this process (the model's searches kept in memory forgotten, as in
    a new process): exit status, standard output, standard error."""
    load("compass_gait")._searches.clear()
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def analyzed(tmp_path_factory):
    """The analysis of ANALYZE in a cache of its own: (its output, the kept search's file
    name and content)."""
    cache = tmp_path_factory.mktemp("search_cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("VSW_CACHE_DIR", str(cache))
        patch.delenv("VSW_SEARCH_CACHE", raising=False)
        code, out, err = run(ANALYZE)
    assert code == 0, err
    (kept,) = (cache / "searches").glob("compass_gait-*.json")
    return json.loads(out), kept.name, kept.read_text()


@pytest.fixture
def kept_search(analyzed, tmp_path, monkeypatch):
    """A private cache holding the analysis's kept search: its path and content."""
    monkeypatch.setenv("VSW_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("VSW_SEARCH_CACHE", raising=False)
    _, name, text = analyzed
    path = tmp_path / "searches" / name
    path.parent.mkdir()
    path.write_text(text)
    return path, json.loads(text)


def shifted_states(data: dict) -> dict:
    gaits_ = data["confirmed"]["gaits"]
    moved = [{**g, "state": {k: v + 0.05 for k, v in g["state"].items()}} for g in gaits_]
    return {**data, "confirmed": {**data["confirmed"], "gaits": moved}}


@pytest.mark.parametrize("sealed", [False, True], ids=["digest-stale", "digest-recomputed"])
def test_kept_gait_states_moved_off_their_orbits_are_not_reported(analyzed, kept_search, sealed):
    """Every kept gait's state plus 0.05: no periodic orbit. With the digest left as it was
    the file is not trusted; with it recomputed, stepping each kept gait once shows it is no
    gait. Either way the search is done again and reports the true gaits, with one note."""
    path, data = kept_search
    altered = shifted_states(data)
    path.write_text(json.dumps(reseal(altered) if sealed else altered))
    code, out, err = run(ANALYZE)
    assert code == 0, err
    result = json.loads(out)
    assert result["fixed_points"] == analyzed[0]["fixed_points"]
    assert result["search"] == analyzed[0]["search"]
    (line,) = err.strip().splitlines()
    assert line.startswith("vsw: warning: the kept search") and path.name in line
    assert line.endswith(": searching again")
    assert ("SHA-256" in line) != sealed
    # The search done again is kept in place of the altered one, and trusted next time.
    assert json.loads(path.read_text()) == data
    assert run(ANALYZE)[1:] == (out, "")


def no_gaits(d: dict) -> dict:
    return {**d, "confirmed": {**d["confirmed"], "gaits": []}}


@pytest.mark.parametrize(
    ("alter", "why"),
    [
        (no_gaits, "Newton solution"),
        (lambda d: {**d, "candidates": -5}, "out of range"),
        (lambda d: {**d, "route": "nosuch"}, "route"),
    ],
    ids=["no-gaits", "candidates", "route"],
)
def test_a_kept_search_emptied_or_out_of_range_is_searched_again(analyzed, kept_search, alter, why):
    """Its gaits emptied (was "no period-one gait in the search box", exit 0), a count out
    of range or an unknown route (were echoed into the JSON), the digest recomputed: not
    used; the output is a new search's, with a one-line note."""
    path, data = kept_search
    path.write_text(json.dumps(reseal(alter(data))))
    code, out, err = run(ANALYZE)
    assert code == 0, err
    result = json.loads(out)
    assert result["fixed_points"] == analyzed[0]["fixed_points"]
    assert result["search"] == analyzed[0]["search"]
    (line,) = err.strip().splitlines()
    assert why in line and "searching again" in line and "Traceback" not in err


FIELDS = [
    (lambda d: {**d, "converged": d["candidates"] + 1}, "out of range"),
    (lambda d: {**d, "candidates": 1.5}, "out of range"),
    (lambda d: {**d, "route": 7}, "route"),
    (lambda d: {**d, "route": "SciPy (no compiler)\nvsw: all is well"}, "route"),
    (lambda d: {**d, "points": {k: v - 1 for k, v in d["points"].items()}}, "grid"),
    (lambda d: {**d, "outcomes": {**d["outcomes"], "walked": 1}}, "outcomes"),
    (lambda d: {**d, "outcomes": {**d["outcomes"], "exploded": 0}}, "outcomes"),
    (lambda d: {**d, "found": [[0.1, "x", 0.3]]}, "Newton solutions"),
    (lambda d: {**d, "found": []}, "count of converged starts"),
    (
        lambda d: {
            **no_gaits(d),
            "found": [],
            "confirmed": {**no_gaits(d)["confirmed"], "standing": 0},
        },
        "converged starts",
    ),
    (lambda d: {**d, "confirmed": {**d["confirmed"], "standing": -1}}, "standing"),
    (lambda d: {**d, "confirmed": {**d["confirmed"], "standing": True}}, "standing"),
    (lambda d: {**d, "confirmed": {**d["confirmed"], "gaits": [{"state": []}]}}, "gait"),
    (lambda d: {**d, "confirmed": {**d["confirmed"], "unconfirmed": [{}]}}, "unconfirmed"),
    (lambda d: {**d, "file": "compass_gait-000000000000000000000000.json"}, "another"),
    (lambda d: {**d, "extra": 1}, "fields"),
]
FIELD_IDS = [
    *"converged candidates-float route-type route-lines grid outcomes outcome-name found".split(),
    *"found-empty found-and-gaits-empty standing standing-bool gait unconfirmed".split(),
    *"renamed extra".split(),
]


def field_gait(data: dict, key: str, value) -> dict:
    gait = {**data["confirmed"]["gaits"][0], key: value}
    return {**data, "confirmed": {**data["confirmed"], "gaits": [gait]}}


FIELDS += [
    (lambda d: field_gait(d, "eigenvalues", [[0.5, 0.0]]), "eigenvalues"),
    (lambda d: field_gait(d, "period", 7.0), "period"),
    (lambda d: field_gait(d, "phase_durations", [-0.1]), "period"),
    (lambda d: field_gait(d, "residual", 1e-3), "residual"),
    (lambda d: field_gait(d, "step_length", "long"), "step length"),
]
FIELD_IDS += ["eigenvalues", "period", "durations", "residual", "step-length"]


@pytest.mark.parametrize(("alter", "why"), FIELDS, ids=FIELD_IDS)
def test_a_kept_search_with_fields_out_of_place_is_not_used(monkeypatch, tmp_path, alter, why):
    """Digest recomputed or not, a kept search whose fields are not what a search writes
    (types, ranges, the grid, the routes and outcomes, the gaits' records, its own file
    name) is not used: searched again, with a one-line note naming what was wrong."""
    monkeypatch.setenv("VSW_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("VSW_SEARCH_CACHE", raising=False)
    m = load("compass_gait")
    params = m.parameters({})
    first = gaits.search(m, params, cells=8_000)
    (kept,) = (tmp_path / "searches").iterdir()
    data = json.loads(kept.read_text())
    assert data["confirmed"]["gaits"]
    for sealed in (False, True):
        kept.write_text(json.dumps(reseal(alter(data)) if sealed else alter(data)))
        with pytest.warns(CacheWarning) as caught:
            again = gaits.search(m, params, cells=8_000)
        assert [o.to_dict() for o in again.gaits] == [o.to_dict() for o in first.gaits]
        assert (again.candidates, again.converged, again.route, again.points) == (
            first.candidates, first.converged, first.route, first.points)  # fmt: skip
        (line,) = [str(w.message) for w in caught]
        assert "searching again" in line and "\n" not in line
        assert why in line or not sealed, line
        assert json.loads(kept.read_text()) == data  # the new search kept in its place


def test_a_kept_search_copied_under_another_searchs_name_is_not_used(monkeypatch, tmp_path):
    """The seal names its file: the search of another slope, copied over this one's file
    with its digest intact, is no answer for this slope."""
    monkeypatch.setenv("VSW_CACHE_DIR", str(tmp_path))
    m = load("compass_gait")
    steep, shallow = m.parameters({"gamma": 0.0333}), m.parameters({})
    gaits.search(m, steep, cells=8_000)
    (steep_file,) = (tmp_path / "searches").iterdir()
    truth = gaits.search(m, shallow, cells=8_000)
    (shallow_file,) = set((tmp_path / "searches").iterdir()) - {steep_file}
    shutil.copyfile(steep_file, shallow_file)
    with pytest.warns(CacheWarning, match="written as another search's file"):
        again = gaits.search(m, shallow, cells=8_000)
    assert [o.to_dict() for o in again.gaits] == [o.to_dict() for o in truth.gaits]


def test_a_kept_gait_is_stepped_again_before_it_is_reported(monkeypatch, tmp_path):
    """The check that catches a sealed file with wrong states: compiled steps from each kept
    gait (its return, its largest |eigenvalue| by finite differences) and from each Newton
    solution, and nothing reported from the file when one fails."""
    monkeypatch.setenv("VSW_CACHE_DIR", str(tmp_path))
    m = load("compass_gait")
    params = m.parameters({})
    first = gaits.search(m, params, cells=8_000)
    (kept,) = (tmp_path / "searches").iterdir()
    data = json.loads(kept.read_text())
    names = [*m.coordinates, *m.rates]
    sim = gaits.simulator(m)
    found, record = data["found"], data["confirmed"]
    assert gaits.recheck(m, sim, params, found, *search_cache.kept_gaits(record, names)) is None
    gait = record["gaits"][0]
    shifted = {"state": {k: v * (1 + 1e-6) for k, v in gait["state"].items()}}
    for changed, why in [
        (shifted, "away"),
        ({"phase_durations": [gait["period"] * 1.001]}, "durations"),
        ({"step_length": gait["step_length"] * 1.001}, "step length"),
        ({"eigenvalues": [[re / 2, im / 2] for re, im in gait["eigenvalues"]]}, "eigenvalue"),
        # An eigenvalue so large that the return's tolerance would take any state.
        ({**shifted, "eigenvalues": [[1e12, 0.0], *gait["eigenvalues"][1:]]}, "eigenvalue"),
    ]:
        wrong = {**record, "gaits": [{**gait, **changed}, *record["gaits"][1:]]}
        problem = gaits.recheck(m, sim, params, found, *search_cache.kept_gaits(wrong, names))
        assert problem is not None and why in problem
    dropped = {**record, "gaits": record["gaits"][1:]}
    assert "neither" in gaits.recheck(m, sim, params, found,
                                      *search_cache.kept_gaits(dropped, names))  # fmt: skip
    calls = []
    scan = gaits._scan
    monkeypatch.setattr(gaits, "_scan", lambda *a: calls.append(1) or scan(*a))
    kept.write_text(json.dumps(reseal({**data, "confirmed": dropped})))
    with pytest.warns(CacheWarning, match="neither a kept gait"):
        again = gaits.search(m, params, cells=8_000)
    assert calls == [1]
    assert [o.to_dict() for o in again.gaits] == [o.to_dict() for o in first.gaits]


# --- cached user-model packages ---------------------------------------------------------------

MODEL_SOURCE = ROOT / "derive" / "models" / "rimless_wheel.py"


def vsw(*argv: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    code = "import sys; from vsw.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *argv], cwd=ROOT,
                          env={**os.environ, **(env or {})}, capture_output=True, text=True,
                          timeout=600)  # fmt: skip


@pytest.fixture(scope="module")
def derived_walker(tmp_path_factory):
    """A user's copy of the rimless wheel's model file, derived once into a cache: (the
    file, the cache, the analysis's output)."""
    base = tmp_path_factory.mktemp("walker")
    path = base / "my_walker.py"
    shutil.copyfile(MODEL_SOURCE, path)
    cache = base / "cache"
    done = vsw("analyze", "--model", str(path), "--json", env={"VSW_CACHE_DIR": str(cache)})
    assert done.returncode == 0, done.stderr
    (line,) = done.stderr.strip().splitlines()  # the note, once the derivation is done
    assert line.startswith(f"vsw: deriving the model of {path}") and " done in " in line
    return path, cache, json.loads(done.stdout)


@pytest.fixture
def walker(derived_walker, tmp_path):
    """A private copy of the derived walker's cache: (the model file, the cache's
    environment, the models directory, the package's directory, the analysis's output)."""
    path, cache, analysis = derived_walker
    mine = tmp_path / "cache"
    shutil.copytree(cache, mine, symlinks=True)
    models = mine / "models"
    (package,) = [p.parent for p in models.glob("my_walker-*/*/__init__.py")]
    return path, {"VSW_CACHE_DIR": str(mine)}, models, package, analysis


def cut_to_half(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


@pytest.mark.parametrize(
    "damage",
    [cut_to_half, lambda p: p.write_text(""), lambda p: p.write_text(p.read_text() + "\n#\n")],
    ids=["truncated", "emptied", "edited"],
)
def test_a_damaged_cached_model_package_is_derived_again(walker, damage):
    """The package's ``__init__.py`` cut to half (was a SyntaxError traceback), emptied (was
    "no hybrid descriptor", never derived again) or edited: it no longer matches its digest,
    so the model is derived again, with one line saying why, and the answer is the same."""
    path, env, _, package, analysis = walker
    damage(package / "__init__.py")
    done = vsw("analyze", "--model", str(path), "--json", env=env)
    assert done.returncode == 0, done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert "does not match its digest" in line and f"deriving the model of {path} again" in line
    assert json.loads(done.stdout)["fixed_points"] == analysis["fixed_points"]
    again = vsw("analyze", "--model", str(path), "--json", env=env)
    assert (again.returncode, again.stderr) == (0, "")


def test_a_cached_package_whose_bytecode_is_damaged_is_derived_again(walker):
    """Python's compiled bytecode beside the package (not under the digest: Python writes
    it) cut short: the import fails, and the package is derived again, in one line."""
    path, env, _, package, analysis = walker
    env = {**env, "PYTHONDONTWRITEBYTECODE": ""}
    assert vsw("models", "--model", str(path), env=env).returncode == 0
    (compiled,) = (package / "__pycache__").glob("__init__.*.pyc")
    cut_to_half(compiled)
    done = vsw("analyze", "--model", str(path), "--json", env=env)
    assert done.returncode == 0, done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert "does not load" in line and "again" in line and "Traceback" not in done.stderr
    assert json.loads(done.stdout)["fixed_points"] == analysis["fixed_points"]


def test_a_cached_package_without_its_digest_or_replaced_by_a_file_is_derived_again(walker):
    """No digest beside the package (written by an older vsw, or removed): derived again.
    A plain file where the package's directory belongs (was "--out ... exists" though no
    --out was given): derived again in its place."""
    path, env, _, package, analysis = walker
    root = package.parent
    root.with_name(root.name + ".sha256.json").unlink()
    done = vsw("analyze", "--model", str(path), "--json", env=env)
    assert done.returncode == 0, done.stderr
    assert "carries no digest" in done.stderr and len(done.stderr.strip().splitlines()) == 1
    shutil.rmtree(root)
    root.write_text("not a package\n")
    done = vsw("analyze", "--model", str(path), "--json", env=env)
    assert done.returncode == 0, done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert "is not a directory" in line and "--out" not in line
    assert json.loads(done.stdout)["fixed_points"] == analysis["fixed_points"]


def test_a_models_directory_that_is_a_file_is_refused_in_one_line(walker, tmp_path):
    path, env, _, _, _ = walker
    blocker = tmp_path / "models_file"
    blocker.write_text("")
    done = vsw("models", "--model", str(path), env={**env, "VSW_MODELS_DIR": str(blocker)})
    assert done.returncode == 2
    (line,) = done.stderr.strip().splitlines()
    assert f"the models directory {blocker} is a file" in line and "--out" not in line


@pytest.mark.parametrize("where", ["models", "cache", "named"])
def test_a_models_directory_anyone_may_write_is_refused(walker, tmp_path, where):
    """Anyone who may write the models directory, or a directory above it, can put a
    package of theirs in place of the cached one: refused in one line (exit 2), as a
    package anyone may write is. A sticky directory (as /tmp) lets nobody rename what is
    not theirs: accepted."""
    path, env, models, _, analysis = walker
    if where == "named":  # VSW_MODELS_DIR, not yet made, in a directory anyone may write
        shared = tmp_path / "shared"
        shared.mkdir()
        env = {**env, "VSW_MODELS_DIR": str(shared / "models")}
        opened = shared
    else:
        opened = models if where == "models" else models.parent
    mode = stat.S_IMODE(opened.stat().st_mode)
    opened.chmod(0o777)
    try:
        done = vsw("analyze", "--model", str(path), "--json", env=env)
        assert done.returncode == 2 and done.stdout == ""
        (line,) = done.stderr.strip().splitlines()
        assert line == (f"vsw: error: {opened} is writable by anyone: no model package under "
                        "it is derived or loaded (make it private, or name another directory "
                        "with VSW_MODELS_DIR)")  # fmt: skip
        if where != "named":
            opened.chmod(0o1777)
            sticky = vsw("analyze", "--model", str(path), "--json", env=env)
            assert sticky.returncode == 0, sticky.stderr
            assert json.loads(sticky.stdout)["fixed_points"] == analysis["fixed_points"]
    finally:
        opened.chmod(mode)


def test_a_directory_named_like_a_model_file_is_called_a_directory(tmp_path, capsys):
    folder = tmp_path / "dir.py"
    folder.mkdir()
    with pytest.raises(VswInputError, match=r"dir\.py is a directory, not a file"):
        user.model_file(str(folder))
    assert main(["models", "--model", str(folder)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "is a directory, not a file" in line and "does not exist" not in line
    with pytest.raises(VswInputError, match="does not exist"):
        user.model_file(str(tmp_path / "none.py"))


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_the_deriving_note_is_erased_on_a_terminal_when_deriving_fails(monkeypatch):
    """On a terminal the note shows while the model derives and is erased if that fails,
    leaving the error's line alone; in a log it is written once the derivation is done."""
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    with pytest.raises(VswInputError), user._deriving_note(Path("w.py"), None):
        assert terminal.getvalue().startswith("vsw: deriving the model of w.py")
        raise VswInputError("deriving w.py failed: no MODEL")
    assert terminal.getvalue().endswith("\r\x1b[K")
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    with user._deriving_note(Path("w.py"), None):
        pass
    (line,) = terminal.getvalue().splitlines()
    assert line.startswith("vsw: deriving the model of w.py") and " done in " in line
    log = io.StringIO()
    monkeypatch.setattr(sys, "stderr", log)
    with pytest.raises(VswInputError), user._deriving_note(Path("w.py"), None):
        assert log.getvalue() == ""
        raise VswInputError("failed")
    assert log.getvalue() == ""
