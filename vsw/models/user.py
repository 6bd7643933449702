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

import contextlib
import functools
import hashlib
import importlib.util
import json
import os
import secrets
import shutil
import stat
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

from vsw.dynamics.compiled import cache_dir, exclusive_lock, write_durably
from vsw.runtime.errors import VswInputError

__all__ = ["ENTRY_POINT_GROUP", "entry_point_file", "is_model_file", "model_file", "package"]

ENTRY_POINT_GROUP = "vsw.models"
DERIVE_TIMEOUT = 1800.0
"""Seconds a model file's derivation may take before it is stopped (a model that takes
longer is an engine problem to report, not to wait for)."""


def is_model_file(name: str) -> bool:
    """Whether a ``--model`` value names a file (it ends in ``.py``) rather than a model."""
    return name.strip().endswith(".py")


def model_file(name: str | Path) -> Path:
    """The absolute path of the model file ``name``, or a one-line refusal saying what it is
    instead (missing, a directory, not a regular file, unreadable)."""
    text = str(name).strip()
    path = Path(text).expanduser().resolve()
    if path.is_dir():
        raise VswInputError(f"model file {text} is a directory, not a file")
    if not path.exists():
        raise VswInputError(f"model file {text} does not exist")
    if not path.is_file():
        raise VswInputError(f"model file {text} is not a regular file")
    if not os.access(path, os.R_OK):
        raise VswInputError(f"model file {text} cannot be read (permission denied)")
    return path


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

    path = model_file(path)
    key = model_file_digest(path)[:16]
    return _load(path, key)


@functools.cache
def _load(path: Path, key: str) -> ModuleType:
    models = _models_dir()
    if models.exists() and not models.is_dir():
        raise VswInputError(
            f"the models directory {models} is a file: remove it, or name another directory "
            "with VSW_MODELS_DIR"
        )
    _refuse_open(models)  # before anything is derived into it or loaded from it
    root = models / f"{path.stem}-{key}"
    with _cache_lock(root):
        derived = _ensure(path, root)
    try:
        return _import(path, root, key)
    except _UnloadableError as exc:
        if derived:  # derived just now: deriving again would give the same
            raise VswInputError(f"model file {path}: its generated package {exc}") from None
        reason = f"{root} {exc}"
    with _cache_lock(root):
        _discard(root)
        _derive_and_seal(path, root, reason)
    try:
        return _import(path, root, key)
    except _UnloadableError as exc:
        raise VswInputError(f"model file {path}: its generated package {exc}") from None


def _ensure(path: Path, root: Path) -> bool:
    """A verified package of ``path`` under ``root``: the cached one, or (none cached, or
    one that is not what was derived there: a note says why) derived now. Whether it was
    derived now."""
    problem = _damage(root)
    if problem is not None:
        _discard(root)
    elif _package_dirs(root):
        return False
    _derive_and_seal(path, root, None if problem is None else f"{root} {problem}")
    return True


@contextlib.contextmanager
def _cache_lock(root: Path) -> Iterator[None]:
    """Exclusive lock on the cached package ``root`` while it is checked, removed, derived
    and sealed, so that a concurrent first run neither takes a package not yet sealed for a
    damaged one nor loads one half removed (:func:`vsw.dynamics.compiled.exclusive_lock`)."""
    with contextlib.suppress(OSError):
        root.parent.mkdir(parents=True, exist_ok=True)
    with exclusive_lock(root):
        yield


class _UnloadableError(Exception):
    """A generated package that does not load (its message: why, after "the package")."""


def _import(path: Path, root: Path, key: str) -> ModuleType:
    """The generated package under ``root``, imported (checked first: :func:`_refuse_foreign`).

    Raises
    ------
    _UnloadableError
        It does not import (a compiled ``__pycache__`` file damaged, say, which the digest
        does not cover), or declares no hybrid model.
    """
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
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # generated code that does not run: one line, not a traceback
        for loaded in [m for m in sys.modules if m == name or m.startswith(f"{name}.")]:
            del sys.modules[loaded]
        where = f"{type(exc).__name__}: {exc}".splitlines()[0]
        raise _UnloadableError(f"does not load ({where})") from None
    if not hasattr(module, "HYBRID"):
        del sys.modules[name]
        raise _UnloadableError("has no hybrid descriptor to run")
    return module


def note(text: str) -> None:
    """One line on stderr about the cache (a package derived again, and why)."""
    print(f"vsw: {text}", file=sys.stderr)


def _refuse_foreign(root: Path) -> None:
    """A cached package is code that will run: refuse one that another user owns or that
    anyone may write (a shared cache directory must not let others plant code); its digest
    (:func:`_seal`) likewise, which vouches for it."""
    uid = os.getuid() if hasattr(os, "getuid") else None
    seal = _seal_file(root)
    for path in [root, *root.rglob("*"), *([seal] if seal.exists() else [])]:
        info = path.stat()
        if (uid is not None and info.st_uid != uid) or info.st_mode & 0o002:
            raise VswInputError(
                f"{path} is another user's or writable by anyone: not loaded (remove {root})"
            )


def _refuse_open(models: Path) -> None:
    """Refuse a models directory under which others could swap a package wholesale, as
    :func:`_refuse_foreign` refuses a package they could edit: the directory (or, before
    it exists, the one it will be made in) and every directory above it must not be
    writable by anyone (unless sticky, as /tmp is: there nobody renames what is not
    theirs), and the models directory must be the user's own (or root's)."""
    uid = os.getuid() if hasattr(os, "getuid") else None
    models = Path(os.path.abspath(models))
    existing = next((d for d in [models, *models.parents] if d.exists()), None)
    if existing is None:
        return
    for directory in [existing, *existing.parents]:
        try:
            info = directory.stat()
        except OSError:
            continue
        if info.st_mode & 0o002 and not info.st_mode & stat.S_ISVTX:
            raise VswInputError(
                f"{directory} is writable by anyone: no model package under it is derived or "
                f"loaded (make it private, or name another directory with VSW_MODELS_DIR)"
            )
    if existing == models and uid is not None and models.stat().st_uid not in (uid, 0):
        raise VswInputError(
            f"{models} is another user's: no model package under it is derived or loaded "
            f"(name another directory with VSW_MODELS_DIR)"
        )


_SEAL_SUFFIX = ".sha256.json"


def _seal_file(root: Path) -> Path:
    """Where the digest of a cached package is kept: beside it (``<stem>-<key>.sha256
    .json``), outside the directory ``python -m derive --file`` replaces whole."""
    return root.with_name(root.name + _SEAL_SUFFIX)


def _package_files(root: Path) -> dict[str, str]:
    """The SHA-256 of every file under ``root`` by relative path, compiled bytecode
    (``__pycache__``, which Python writes and checks itself) left out. OSError for a file
    that cannot be read, and for a link (derive writes none)."""
    out = {}
    for path in sorted(root.rglob("*")):
        relative = path.relative_to(root)
        if "__pycache__" in relative.parts:
            continue
        if path.is_symlink():
            raise OSError(f"{relative} is a link")
        if path.is_file():
            out[relative.as_posix()] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def _seal(root: Path) -> None:
    """Record the digest of the package just derived under ``root``
    (:func:`vsw.dynamics.compiled.write_durably`: a reader never sees part of it)."""
    record = {"package": root.name, "files": _package_files(root)}
    write_durably(_seal_file(root), json.dumps(record, sort_keys=True).encode())


def _damage(root: Path) -> str | None:
    """Why the package cached under ``root`` is not the one derived there (its files not
    those its digest records, the digest missing, or no directory), or None: none cached,
    or verified."""
    if not os.path.lexists(root):
        return None
    if root.is_symlink() or not root.is_dir():
        return "is not a directory"
    _refuse_foreign(root)  # a foreign package is refused, never derived over
    try:
        record = json.loads(_seal_file(root).read_text())
    except FileNotFoundError:
        return "carries no digest" if any(root.iterdir()) else None
    except (OSError, ValueError):
        return "has a damaged digest"
    try:
        files = _package_files(root)
    except OSError as exc:
        return f"cannot be verified ({exc})"
    if not isinstance(record, dict) or record.get("package") != root.name:
        return "has a damaged digest"
    if record.get("files") != files:
        return "does not match its digest"
    return None


def _discard(root: Path) -> None:
    """Remove a damaged cached package (renamed first, so that no reader sees it half
    removed) and its digest; a one-line refusal where it cannot be removed."""
    try:
        if root.is_symlink() or (os.path.lexists(root) and not root.is_dir()):
            root.unlink()
        elif root.exists():
            away = root.with_name(f".{root.name}.{os.getpid()}.{secrets.token_hex(4)}")
            root.rename(away)
            shutil.rmtree(away, ignore_errors=True)
        _seal_file(root).unlink(missing_ok=True)
    except OSError as exc:
        raise VswInputError(
            f"{root} is no usable model package and cannot be removed ({exc.strerror}): "
            "remove it and run again"
        ) from None


def _derive_and_seal(path: Path, root: Path, damaged: str | None = None) -> None:
    """Derive the model file into ``root`` (:func:`_derive`) and record its digest; the note
    that it is being derived (and why again: ``damaged``, what was wrong with the cached
    package) is the only line on success and none on failure (the error's line stands
    alone)."""
    with _deriving_note(path, damaged):
        _derive(path, root)
    try:
        _seal(root)
    except OSError as exc:  # a cache that cannot be written: derived again next time
        note(f"the digest of {root} could not be written ({exc.strerror})")


@contextlib.contextmanager
def _deriving_note(path: Path, damaged: str | None) -> Iterator[None]:
    """Say that ``path`` is being derived (seconds to minutes; ``damaged``: the cached
    package that was not used, and why): on a terminal at once, and erased if it fails;
    elsewhere (a log) once it is done."""
    if damaged is None:
        text = f"vsw: deriving the model of {path} (once per change of the file) ..."
    else:
        text = f"vsw: the cached model package {damaged}: deriving the model of {path} again ..."
    live = sys.stderr.isatty()
    if live:
        sys.stderr.write(text)
        sys.stderr.flush()
    started = time.monotonic()
    try:
        yield
    except BaseException:
        if live:
            sys.stderr.write("\r\x1b[K")
            sys.stderr.flush()
        raise
    took = f" done in {time.monotonic() - started:.1f} s"
    print(took if live else text + took, file=sys.stderr)


def _package_dirs(root: Path) -> list[Path]:
    if not root.is_dir():
        return []
    return sorted(p.parent for p in root.glob("*/__init__.py"))


def _derive(path: Path, root: Path) -> None:
    """``python -m derive --file path --out root`` (written atomically by derive itself)."""
    # -P: the working directory is not put on sys.path, so a `derive/` there cannot stand
    # in for the engine the cache key was computed from.
    command = [sys.executable, "-P", "-m", "derive", "--file", str(path), "--out", str(root)]
    # The derivation lives no longer than this process: a stop (Ctrl-C, the run-time
    # limit: vsw.runtime.stop) raised while it waits kills it (subprocess.run), and a vsw ended
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
