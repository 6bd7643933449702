"""The wheel and the sdist install and run outside the repository; the version is one.

``python -m build`` makes both (the wheel from the sdist, so the sdist is checked to build
it); the wheel goes into a fresh virtual environment outside the repository, and the
commands run from a directory outside it: ``vsw analyze``, ``vsw models``, ``vsw
--version``, ``python -m derive --check`` (and ``python -m derive``, which refuses to
rewrite an installed ``generated/``) and ``python -m paper_check``, with a fresh kernel
cache so that the C sources are compiled from the installed package.

The environment reuses this interpreter's numpy, SciPy, sympy, CasADi and the rest
(offline, and seconds instead of minutes): a ``.pth`` file in the venv names their
site-packages directories as plain path lines. ``--system-site-packages`` would do that
too, but it also runs that directory's ``.pth`` files, among them the editable install's,
whose import finder serves any ``vsw``, ``derive`` or ``generated`` module missing from the
wheel out of the checkout and would hide it; a path line runs nothing. The wheel goes in
with ``--no-deps`` (its dependencies are those directories) and ``--ignore-installed``
(pip sees the editable install's metadata there).
"""

from __future__ import annotations

import json
import os
import re
import site
import subprocess
import sys
import tomllib
import zipfile
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as installed_version
from pathlib import Path
from types import SimpleNamespace

import pytest

import vsw

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("derive", "generated", "paper_check", "vsw")

# Goswami, Thuilot & Espiau (1996) at 3 degrees, as quoted in docs/models/passive_walkers.md:
# half inter-leg angle 0.271 rad (printed to 3 decimals), step period 0.735 s (read off a
# figure, +-2 %), stride-map eigenvalue moduli 0.332 (the step map's squared, the gait being
# symmetric; ours are 1.3 % from it, the page says, so 2 % is allowed).
GOSWAMI_HALF_ANGLE, GOSWAMI_PERIOD, GOSWAMI_STRIDE_EIGENVALUE = 0.271, 0.735, 0.332


def _run(command: list[str], cwd: Path, env: dict[str, str], timeout: float = 900):
    return subprocess.run(
        command, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout
    )


def _build_command(outdir: Path) -> list[str]:
    """``python -m build``, without build isolation when this interpreter already has the
    build backend pyproject.toml asks for (no download, and faster); else isolated (it then
    needs PyPI or a local index)."""
    from packaging.requirements import Requirement

    command = [sys.executable, "-m", "build", "--outdir", str(outdir)]
    requires = tomllib.loads((ROOT / "pyproject.toml").read_text())["build-system"]["requires"]
    for text in requires:
        requirement = Requirement(text)
        try:
            if installed_version(requirement.name) not in requirement.specifier:
                return [*command, str(ROOT)]
        except PackageNotFoundError:
            return [*command, str(ROOT)]
    return [*command, "--no-isolation", str(ROOT)]


def _dependency_paths() -> list[str]:
    """The site-packages directories this interpreter imports its dependencies from."""
    paths = list(site.getsitepackages())
    if site.ENABLE_USER_SITE and os.path.isdir(site.getusersitepackages()):
        paths.append(site.getusersitepackages())
    return paths


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> SimpleNamespace:
    """The built sdist and wheel, a venv with the wheel installed, a working directory
    outside the repository and the environment to run the venv's commands in."""
    pytest.importorskip("build", reason="python -m build is not installed (pip install build)")
    base = tmp_path_factory.mktemp("wheel")
    assert not base.resolve().is_relative_to(ROOT), "the temporary directory is in the repository"
    dist = base / "dist"
    done = _run(_build_command(dist), cwd=base, env=dict(os.environ))
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    (wheel,) = dist.glob("vsw-*.whl")
    (sdist,) = dist.glob("vsw-*.tar.gz")

    venv = base / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    purelib = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
        capture_output=True, text=True, check=True,
    ).stdout.strip()  # fmt: skip
    Path(purelib, "vsw-test-dependencies.pth").write_text("\n".join(_dependency_paths()) + "\n")
    install = [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps"]
    install += ["--no-index", "--ignore-installed", "--disable-pip-version-check", str(wheel)]
    done = _run(install, cwd=base, env=dict(os.environ))
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]

    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env["VSW_CACHE_DIR"] = str(base / "cache")  # empty: every library compiled afresh
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    cwd = base / "elsewhere"
    cwd.mkdir()
    return SimpleNamespace(
        wheel=wheel, sdist=sdist, venv=venv.resolve(), python=str(python),
        vsw=str(venv / "bin" / "vsw"), site=Path(purelib).resolve(), cwd=cwd, env=env,
        cache=base / "cache",
    )  # fmt: skip


def _tracked_package_files() -> set[str]:
    """The files of the four packages in the checkout (git's list, so that a stray file
    of someone's work in progress is not asked for; a walk where there is no git)."""
    done = subprocess.run(
        ["git", "ls-files", "-z", "--", *PACKAGES], cwd=ROOT, capture_output=True, text=True
    )
    if done.returncode == 0 and done.stdout:
        names = set(done.stdout.strip("\0").split("\0"))
    else:
        names = {
            p.relative_to(ROOT).as_posix()
            for package in PACKAGES
            for p in (ROOT / package).rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.suffix not in (".pyc", ".so")
        }
    return {n for n in names if (ROOT / n).is_file()}


@pytest.mark.slow
def test_the_wheel_holds_every_package_file_and_the_sdist_what_checks_it(installed):
    wheel = set(zipfile.ZipFile(installed.wheel).namelist())
    missing = sorted(_tracked_package_files() - wheel)
    assert not missing, f"not in the wheel: {missing}"
    for data in (
        "generated/MANIFEST",
        "vsw/dynamics/csrc/hybrid_batch.c",
        "derive/templates/model.js.in",
    ):
        assert data in wheel  # the control: names as the wheel spells them
    import tarfile

    with tarfile.open(installed.sdist) as tar:
        top = {name.split("/", 2)[1] for name in tar.getnames() if name.count("/") >= 1}
    expected = {"tests", "docs", "benchmarks", "mkdocs.yml", "CHANGELOG.md", "pyproject.toml"}
    assert {*expected, "MANIFEST.in", *PACKAGES} <= top


@pytest.mark.slow
def test_the_venv_imports_the_wheel_not_the_checkout(installed):
    code = (
        "import json, sys, derive, generated, paper_check, vsw\n"
        "from importlib.metadata import distribution\n"
        "print(json.dumps({'files': [m.__file__ for m in (derive, generated, paper_check, vsw)],"
        " 'finders': [getattr(f, '__module__', '') or type(f).__module__ for f in sys.meta_path],"
        " 'metadata': str(distribution('vsw').locate_file(''))}))"
    )
    done = _run([installed.python, "-c", code], installed.cwd, installed.env)
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout)
    for file in found["files"]:
        assert Path(file).resolve().is_relative_to(installed.site), file
    assert not [f for f in found["finders"] if "editable" in f], found["finders"]
    assert Path(found["metadata"]).resolve() == installed.site
    assert Path(installed.vsw).read_text().startswith(f"#!{installed.venv}")


@pytest.mark.slow
def test_version_is_the_wheels(installed):
    wheel_version = installed.wheel.name.split("-")[1]
    done = _run([installed.vsw, "--version"], installed.cwd, installed.env)
    assert (done.returncode, done.stdout) == (0, f"vsw {wheel_version}\n"), done.stderr
    assert wheel_version == vsw.__version__


def _stable_gait(text: str) -> dict[str, str]:
    """The fields of the one gait ``vsw analyze`` reports stable (text output)."""
    gaits = re.split(r"^gait \d+$", text, flags=re.M)[1:]
    rows = [dict(re.findall(r"^  (\S.*?)\s{2,}(\S+)", g, flags=re.M)) for g in gaits]
    stable = [r for r in rows if r.get("stable") == "yes"]
    assert len(stable) == 1, text
    return stable[0]


@pytest.mark.slow
def test_analyze_finds_goswamis_compass_gait_with_the_installed_c(installed):
    command = [installed.vsw, "analyze", "--model", "compass-gait", "--param", "gamma=3deg"]
    done = _run(command, installed.cwd, installed.env)
    assert done.returncode == 0, done.stderr
    assert "(compiled)" in done.stdout, done.stdout  # the search ran on the batch simulator
    gait = _stable_gait(done.stdout)
    assert abs(float(gait["psi"]) - GOSWAMI_HALF_ANGLE) <= 5e-4, gait
    assert float(gait["period"]) == pytest.approx(GOSWAMI_PERIOD, rel=0.02), gait
    stride = float(gait["max |eigenvalue|"]) ** 2
    assert stride == pytest.approx(GOSWAMI_STRIDE_EIGENVALUE, rel=0.02), gait
    assert list(installed.cache.glob("libvsw_compass_gait_sim_*.so")), "nothing compiled"

    # Every C source the runtime compiles is the installed package's, and it compiles.
    code = (
        "import json, vsw.dynamics.batch as b\n"
        "from vsw.models import load\n"
        "from vsw.models.ile import kernels\n"
        "lib = kernels.library()\n"
        "print(json.dumps({'csrc': str(b.CSRC), 'sim': str(b.simulator(load('compass-gait'))"
        ".source), 'ile': str(kernels.SOURCE), 'built': str(kernels.library_path),"
        " 'error': kernels.build_error}))"
    )
    done = _run([installed.python, "-c", code], installed.cwd, installed.env)
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout)
    assert found["error"] is None, found["error"]
    for key in ("csrc", "sim", "ile"):
        assert Path(found[key]).resolve().is_relative_to(installed.site), found
    assert Path(found["built"]).parent == installed.cache


@pytest.mark.slow
def test_models_lists_every_registered_model(installed):
    from derive.registry import MODEL_NAMES

    done = _run([installed.vsw, "models"], installed.cwd, installed.env)
    assert done.returncode == 0, done.stderr
    listed = set(re.findall(r"^([a-z0-9-]+): ", done.stdout, flags=re.M))
    assert listed == {name.replace("_", "-") for name in MODEL_NAMES}


@pytest.mark.slow
def test_derive_checks_the_installed_generated_and_refuses_to_rewrite_it(installed):
    wheel = zipfile.ZipFile(installed.wheel).namelist()
    n_generated = sum(name.startswith("generated/") for name in wheel)
    done = _run([installed.python, "-m", "derive", "--check"], installed.cwd, installed.env)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"generated/ is up to date ({n_generated} files"), done.stdout

    done = _run([installed.python, "-m", "derive"], installed.cwd, installed.env)
    assert done.returncode == 2, done.stdout + done.stderr
    assert len(done.stderr.splitlines()) == 1 and "source checkout" in done.stderr

    # The check is real: a changed installed file is found (its model derived again).
    target = installed.site / "generated" / "rimless_wheel" / "js" / "rimless_wheel.js"
    original = target.read_text()
    target.write_text(original + "// changed\n")
    try:
        done = _run([installed.python, "-m", "derive", "--check"], installed.cwd, installed.env)
    finally:
        target.write_text(original)
    assert done.returncode == 1 and "rimless_wheel.js" in done.stderr, done.stderr


@pytest.mark.slow
def test_paper_check_runs_from_the_wheel(installed):
    out = installed.cwd / "reports"  # its default: reports/ in the working directory
    done = _run([installed.python, "-m", "paper_check"], installed.cwd, installed.env)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    for name in ("audit.md", "audit.json"):
        assert (out / name).stat().st_size > 0
    assert json.loads((out / "audit.json").read_text())["equations"]


def test_the_version_is_written_once():
    """pyproject.toml takes it from vsw.__version__; CITATION.cff (which cannot read it)
    must say the same."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    attr = project["tool"]["setuptools"]["dynamic"]["version"]["attr"]
    assert attr == "vsw.__version__"
    assert re.fullmatch(r"\d+\.\d+\.\d+", vsw.__version__)
    citation = re.search(r'^version: "([^"]+)"$', (ROOT / "CITATION.cff").read_text(), re.M)
    assert citation is not None and citation.group(1) == vsw.__version__


def test_build_outputs_are_ignored_by_git():
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout (an unpacked sdist)")
    for path in ("dist/vsw-0.1.0.tar.gz", "build/lib/vsw/__init__.py", "vsw.egg-info/PKG-INFO"):
        done = subprocess.run(["git", "check-ignore", "-q", path], cwd=ROOT)
        assert done.returncode == 0, f"{path} is not ignored by git"


def test_derive_refuses_to_rewrite_an_installed_generated(tmp_path, monkeypatch, capsys):
    """Without pyproject.toml beside derive/ (an installed copy), ``python -m derive``
    refuses in one line and writes nothing; the checkout itself has one."""
    import derive.__main__ as derive_main

    assert (derive_main.ROOT / "pyproject.toml").is_file()
    monkeypatch.setattr(derive_main, "ROOT", tmp_path)
    assert derive_main.main([]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and str(tmp_path) in err
    assert list(tmp_path.iterdir()) == []
