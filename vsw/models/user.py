"""Models declared outside the package: a model file of the user's, or a package's entry point.

``--model path/to/my_walker.py`` (any command) names a file that declares a model in the
engine's language, as ``derive/models/*.py`` do (``MODEL``, and ``derive()`` or
``UNITS``). Its generated package is written by ``python -m derive --file`` (a separate
process: the runtime never imports sympy) into a cache directory keyed by the SHA-256 of
the file, the engine and the versions that shape the output
(:func:`derive.manifest.model_file_digest`): ``$VSW_CACHE_DIR/models/<stem>-<key>/``
(default ``~/.cache/vsw``), or ``$VSW_MODELS_DIR/<stem>-<key>/`` where the user names
one. A changed file or engine is a new key (a file the model file imports is not part of
it: clear the directory after editing one); the first command on a new key derives it
(seconds), the next ones load it.

A package can ship models as entry points of the group ``vsw.models``
(``my_walkers.kneed = "my_walkers.kneed"``: the module of a model file); ``--model
kneed`` then finds its file without importing it.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import subprocess
import sys
from pathlib import Path
from types import ModuleType

from vsw.compiled import cache_dir
from vsw.errors import VswInputError

__all__ = ["ENTRY_POINT_GROUP", "entry_point_file", "is_model_file", "package"]

ENTRY_POINT_GROUP = "vsw.models"
DERIVE_TIMEOUT = 1800.0
"""Seconds a model file's derivation may take before it is stopped (a model that takes
longer is an engine problem to report, not to wait for)."""


def is_model_file(name: str) -> bool:
    """Whether a ``--model`` value names a file (it ends in ``.py``) rather than a model."""
    return name.strip().endswith(".py")


def entry_point_file(name: str) -> Path | None:
    """The model file an installed package declares under ``name`` (group ``vsw.models``),
    found without importing it; None when no package declares it."""
    # Imported here, not above: importlib.metadata costs about 25 ms, which every command
    # would pay at start-up for a lookup only an unknown model name needs (--version
    # defers it likewise).
    import importlib.metadata

    for entry in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        if entry.name == name:
            try:
                spec = importlib.util.find_spec(entry.module)
            except (ImportError, ValueError) as exc:
                raise VswInputError(f"model {name!r}: its module {entry.module}: {exc}") from None
            if spec is None or spec.origin is None:
                raise VswInputError(f"model {name!r}: its module {entry.module} is not found")
            return Path(spec.origin)
    return None


def _models_dir() -> Path:
    named = os.environ.get("VSW_MODELS_DIR")
    return Path(named) if named else cache_dir() / "models"


def package(path: Path) -> ModuleType:
    """The generated package of the model file ``path``, derived first if not cached."""
    # The engine's digest (derive.manifest imports importlib.metadata) is needed only when a
    # model file is named: imported here so that no other command pays for it at start-up.
    from derive.manifest import model_file_digest

    path = Path(path).resolve()
    if not path.is_file():
        raise VswInputError(f"model file {path} does not exist")
    key = model_file_digest(path)[:16]
    return _load(path, key)


@functools.cache
def _load(path: Path, key: str) -> ModuleType:
    root = _models_dir() / f"{path.stem}-{key}"
    if not _package_dirs(root):
        _derive(path, root)
    found = _package_dirs(root)
    if len(found) != 1:
        raise VswInputError(f"{root} holds no single generated model: remove it and run again")
    directory = found[0]
    _refuse_foreign(root)
    name = f"vsw_model_{directory.name}_{key}"
    spec = importlib.util.spec_from_file_location(
        name, directory / "__init__.py", submodule_search_locations=[str(directory)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    if not hasattr(module, "HYBRID"):
        raise VswInputError(f"model file {path}: its model has no hybrid descriptor to run")
    return module


def _refuse_foreign(root: Path) -> None:
    """A cached package is code that will run: refuse one that another user owns or that
    anyone may write (a shared cache directory must not let others plant code)."""
    uid = os.getuid() if hasattr(os, "getuid") else None
    for path in [root, *root.rglob("*")]:
        info = path.stat()
        if (uid is not None and info.st_uid != uid) or info.st_mode & 0o002:
            raise VswInputError(
                f"{path} is another user's or writable by anyone: not loaded (remove {root})"
            )


def _package_dirs(root: Path) -> list[Path]:
    if not root.is_dir():
        return []
    return sorted(p.parent for p in root.glob("*/__init__.py"))


def _derive(path: Path, root: Path) -> None:
    """``python -m derive --file path --out root`` (written atomically by derive itself)."""
    # -P: the working directory is not put on sys.path, so a `derive/` there cannot stand
    # in for the engine the cache key was computed from.
    command = [sys.executable, "-P", "-m", "derive", "--file", str(path), "--out", str(root)]
    print(f"vsw: deriving the model of {path} (once per change of the file) ...", file=sys.stderr)
    # The derivation lives no longer than this process: a stop (Ctrl-C, the run-time
    # limit: vsw.stop) raised while it waits kills it (subprocess.run), and a vsw ended
    # by a signal it cannot handle (SIGTERM, SIGKILL) has the kernel kill it (Linux's
    # PR_SET_PDEATHSIG, set in the child before it runs; a parent already gone by then is
    # caught by the parent id check).
    parent = os.getpid()
    try:
        import ctypes

        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        prctl = None

    def tie_to_parent() -> None:
        if prctl is not None:
            prctl(1, 9, 0, 0, 0)  # PR_SET_PDEATHSIG, SIGKILL
        if os.getppid() != parent:
            os._exit(1)

    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=DERIVE_TIMEOUT,
                              preexec_fn=tie_to_parent)  # fmt: skip
    except subprocess.TimeoutExpired:
        raise VswInputError(
            f"deriving {path} took more than {DERIVE_TIMEOUT:g} s and was stopped"
        ) from None
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines() or ["no message"]
        raise VswInputError(
            f"deriving {path} failed: {lines[-1].removeprefix('python -m derive: ')}"
        )
