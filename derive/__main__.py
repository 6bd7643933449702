"""``python -m derive [--check]``: write ``generated/`` from the derivations, or check it.

Write mode renders every file in memory, writes them into a staging directory beside
``generated/`` (``.generated.<pid>.<random>``) and swaps the two directories, so an
interrupted run never leaves a half-written ``generated/``. On Linux the swap is one
``renameat2(RENAME_EXCHANGE)``: ``generated/`` is never missing. Where the kernel or the
filesystem cannot exchange, it is two renames, and ``generated/`` is missing between them
(a kill there leaves ``.generated.old``, which the next run moves back first). Runs hold
a lock on the parent directory, and each removes the staging leftovers of killed runs
before it writes. The new files and directories keep the modes of the ones they replace
(new ones get the umask's defaults). Check mode renders in memory and compares byte for
byte.

An installed copy (a wheel, no ``pyproject.toml`` beside ``derive/``) checks its
``generated/`` (``--check``) and derives into ``--out DIR``; writing its own ``generated/``
is refused (exit 2, one line): that needs a source checkout.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import difflib
import errno
import os
import secrets
import shutil
import signal
import stat
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

# sympy memoises its core operations in an LRU cache of 1000 entries by default, which the
# two-link walkers' derivations overflow: with 20000 every model derives in 16.8 s of CPU
# instead of 18.6 s (the same files; 5000: 17.4 s, 50000: 17.0 s; 140 MB resident). It is
# read when sympy is first imported, which is after this (the workers import it).
os.environ.setdefault("SYMPY_CACHE_SIZE", "20000")

from derive import manifest
from derive.registry import MODEL_GROUPS, MODEL_MODULES, MODEL_NAMES
from derive.workers import map_in_workers, spare_cores

ROOT = Path(__file__).resolve().parent.parent
FIX_COMMAND = "python -m derive"


# The renderers and the models are imported where a model is derived, not above: they
# import sympy, most of a second, which a run with nothing to derive must not pay.
def _render_model(name: str) -> dict[str, str]:
    """One model's files (run in a worker process: models derive independently). Only
    the model's own module is imported (with what it imports), not every model's. Derived
    alone, its functions are printed over the idle cores (:func:`derive.render.print_ahead`)."""
    import importlib

    from derive import render

    derivation = importlib.import_module(MODEL_MODULES[name]).derive()
    return render.render(derivation, workers=spare_cores())


def _render_group(names: tuple[str, ...]) -> list[dict[str, str]]:
    """Models' files, one after the other in one process (a worker's task): a model that
    shares a phase's dynamics with one derived before it in the process takes them from
    the engine's cache (:data:`derive.registry.MODEL_GROUPS`)."""
    return [_render_model(name) for name in names]


FILE_MARKER = ".derived-by-vsw"
FILE_MARKER_TEXT = "Written by `python -m derive --file`: this directory is replaced on each run.\n"
"""Marks a ``--file`` output: the only non-empty directory ``--out`` may replace."""


class ModelFileError(Exception):
    """A model file that declares no model (reported in one line)."""


def render_model_file(path: Path) -> dict[str, str]:
    """The files of a model declared in a file of the user's own (``--file``): its module
    defines ``derive()`` returning a Derivation, as the built-in models do, or just
    ``MODEL`` (an engine :class:`~derive.engine.model.Model`, with ``UNITS``: a sentence on
    its units for the generated docstrings). Its directory is put on ``sys.path`` so that
    it can import its neighbours."""
    import importlib.util

    from derive import render
    from derive.engine import model_derivation

    path = Path(path).resolve()
    sys.path.insert(0, str(path.parent))
    spec = importlib.util.spec_from_file_location(f"derive_user_model_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise ModelFileError(f"{path} is not a Python file")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    if hasattr(module, "derive"):
        derivation = module.derive()
    elif hasattr(module, "MODEL"):
        units = getattr(module, "UNITS", "Units as the parameter table states.")
        derivation = model_derivation(module.MODEL, units)
    else:
        raise ModelFileError(f"{path} defines neither derive() nor MODEL")
    if not derivation.model.isidentifier():
        raise ModelFileError(f"{path}: the model's name {derivation.model!r} is no identifier")
    files = render.render(derivation, workers=spare_cores())
    return {**files, **_render_shared_backend(), FILE_MARKER: FILE_MARKER_TEXT}


def _render_shared_backend() -> dict[str, str]:
    """Beside a user's model, the backend it was generated against (for reading; the model
    imports the installed ``generated._backend``)."""
    from derive import render

    return {"_backend.py": render.render_shared([])["_backend.py"]}


def _render_shared() -> dict[str, str]:
    """The files every model shares (``generated/__init__.py``, the backend)."""
    from derive import render

    return render.render_shared([SimpleNamespace(model=name) for name in MODEL_NAMES])


def _terminated(signum: int, _frame) -> None:
    """SIGTERM in the parent: unwind (so that the workers are stopped), exit 128 + 15."""
    raise SystemExit(128 + signum)


def render_all(
    only: str | None = None, existing: dict[str, str] | None = None, *, reuse: bool = False
) -> dict[str, str]:
    """Every file of ``generated/`` as ``{relative path: text}``, its manifest included.

    The models are derived in parallel worker processes (each is deterministic, so the
    output does not depend on the scheduling). With ``only``, that model is derived and
    every other model's files are taken from ``existing`` (what is on disk) unchanged.
    With ``reuse``, a model whose inputs and files on disk are as its manifest entry
    records (:mod:`derive.manifest`) is taken from ``existing`` instead of derived.
    """
    existing = existing or {}
    digests = manifest.input_digests()
    kept = manifest.unchanged(existing, digests) if reuse else set()
    names = [name for name in MODEL_NAMES if only in (None, name) and name not in kept]
    as_on_disk = kept | ({entry for entry in MODEL_NAMES if entry != only} if only else set())
    files = {
        path: text
        for path, text in existing.items()
        if path != manifest.MANIFEST
        and (
            manifest.entry_of(path) in as_on_disk
            # With `only`, whatever else lies in a directory of generated/ stays.
            or (only and "/" in path and not path.startswith(f"{only}/"))
        )
    }
    shared = _render_shared() if manifest.SHARED not in kept else {}
    files.update(shared)
    workers = min(len(names), len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                  else os.cpu_count() or 1)  # fmt: skip
    if workers > 1:
        # A worker's task is a group of models that share a phase's dynamics (derived once
        # in the worker, MODEL_GROUPS), or one model; the large tasks first, so the workers
        # finish closer together. The size of a model's generated module on disk is a rough
        # stand-in for its derivation time. The order only schedules; each model's files are
        # its own.
        def cost(name: str) -> int:
            module = ROOT / "generated" / name / "__init__.py"
            return module.stat().st_size if module.is_file() else 0

        tasks = [tuple(n for n in group if n in names) for group in MODEL_GROUPS]
        grouped = {n for task in tasks for n in task}
        tasks = [task for task in tasks if task] + [(n,) for n in names if n not in grouped]
        tasks.sort(key=lambda task: sum(cost(n) for n in task), reverse=True)
        _import_for_workers(names)
        results = map_in_workers(_render_group, tasks, workers)
        by_name = {n: files for task, group in zip(tasks, results) for n, files in zip(task, group)}
        rendered = [by_name[name] for name in names]
    else:
        rendered = [_render_model(name) for name in names]
    for model_files in rendered:
        files.update(model_files)
    # The manifest vouches for what was derived now or found as recorded: a model taken
    # from disk because of `only` keeps its recorded entry as it was (its files on disk,
    # edited or not, are not hashed into it), and the shared entry lists only the files
    # rendered, not whatever else lies in generated/.
    recorded = manifest.parse(existing.get(manifest.MANIFEST, ""))
    entries = {e: r for e, r in recorded.items() if e in as_on_disk - kept}
    shared_paths = set(_shared_paths(existing)) if manifest.SHARED in kept else set(shared)
    for entry in [manifest.SHARED, *MODEL_NAMES]:
        if entry in as_on_disk - kept:
            continue
        paths = shared_paths if entry == manifest.SHARED else {
            p for p in files if manifest.entry_of(p) == entry
        }  # fmt: skip
        entries[entry] = manifest.Entry(digests[entry], manifest.hashes(files, paths))
    files[manifest.MANIFEST] = manifest.render(entries)
    return dict(sorted(files.items()))


def _import_for_workers(names: list[str]) -> None:
    """Import what every worker imports, once, before they fork (they share it): the
    engine and the models to derive, the renderers, CasADi for the C path, and sympy's
    units, which its simplify imports on its first call (0.2 s; every engine model
    simplifies its weight)."""
    import importlib

    import derive.render  # noqa: F401

    for name in names:
        importlib.import_module(MODEL_MODULES[name])
    with contextlib.suppress(ImportError):
        import casadi  # noqa: F401
    import sympy.physics.units  # noqa: F401


def _shared_paths(existing: dict[str, str]) -> list[str]:
    """The shared files the manifest on disk lists (those it was checked against)."""
    entry = manifest.parse(existing.get(manifest.MANIFEST, "")).get(manifest.SHARED)
    return list(entry.files) if entry else []


def existing_files(directory: Path) -> dict[str, str]:
    if not directory.is_dir():
        return {}
    return {
        p.relative_to(directory).as_posix(): p.read_text()
        for p in sorted(directory.rglob("*"))
        if p.is_file() and "__pycache__" not in p.parts
    }


def stale_report(expected: dict[str, str], directory: Path, max_lines: int = 40) -> list[str]:
    """Differences between rendered files and ``directory``; empty when up to date."""
    actual = existing_files(directory)
    lines: list[str] = []
    for path in sorted(set(expected) | set(actual)):
        if path not in actual:
            lines.append(f"missing: generated/{path}")
        elif path not in expected:
            lines.append(f"not generated by the derivation: generated/{path}")
        elif actual[path] != expected[path]:
            diff = difflib.unified_diff(
                actual[path].splitlines(),
                expected[path].splitlines(),
                f"generated/{path} (on disk)",
                f"generated/{path} (derived)",
                lineterm="",
                n=1,
            )
            lines.extend(list(diff)[: max_lines // 2])
    return lines[:max_lines]


@contextlib.contextmanager
def _locked(directory: Path) -> Iterator[bool]:
    """Hold an exclusive lock on ``directory`` (the output's parent) while writing.

    Concurrent runs then write one after the other, and a run holding the lock knows
    that every staging directory it finds was left by a run that is gone. Yields False
    where no lock could be taken (no ``fcntl``, or a filesystem that refuses it).
    """
    try:
        import fcntl

        fd = os.open(directory, os.O_RDONLY)
    except (ImportError, OSError):
        yield False
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            locked = True
        except OSError:
            locked = False
        yield locked
    finally:
        os.close(fd)  # releases the lock


_RENAME_EXCHANGE = 2  # linux/fs.h
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Swap two existing paths in one step (Linux ``renameat2(RENAME_EXCHANGE)``).

    Returns False where that is not available (other systems, old kernels or C libraries,
    filesystems without support); raises OSError for other failures.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):  # glibc < 2.28, or another C library without it
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p]
    renameat2.argtypes += [ctypes.c_uint]
    renameat2.restype = ctypes.c_int
    done = renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    if done == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP, errno.ENOTSUP):
        return False
    raise OSError(code, os.strerror(code), str(a))


def _owner_alive(name: str) -> bool:
    """Whether the process named in ``.<dir>.<pid>.<random>`` still runs."""
    parts = name.split(".")
    if len(parts) != 4 or not parts[2].isdigit():
        return False
    try:
        os.kill(int(parts[2]), 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def _leftovers(directory: Path, locked: bool) -> list[Path]:
    """Staging and backup directories that killed runs left beside ``directory``.

    Holding the lock, every one is stale; without it, those whose run is alive are kept.
    """
    prefix = f".{directory.name}."
    return sorted(
        p
        for p in directory.parent.iterdir()
        if p.name.startswith(prefix) and p.is_dir() and (locked or not _owner_alive(p.name))
    )


_OLD_STAGING_MODE = 0o700
"""What earlier versions left on generated/ (``tempfile.mkdtemp``'s mode); not copied."""


def _copy_modes(old: Path, new: Path) -> None:
    """Give each directory and file of ``new`` the permission bits of its counterpart in
    ``old`` where there is one (``mkdir`` and ``open`` gave the others the umask's)."""
    for path in [new, *sorted(new.rglob("*"))]:
        counterpart = old / path.relative_to(new)
        with contextlib.suppress(OSError):
            mode = stat.S_IMODE(counterpart.stat().st_mode)
            if path == new and mode == _OLD_STAGING_MODE:
                continue  # repair it to what a checkout has (the umask's, as mkdir gave)
            if counterpart.is_dir() == path.is_dir():
                os.chmod(path, mode)


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_atomically(files: dict[str, str], directory: Path) -> None:
    """Replace ``directory`` by exactly ``files`` (relative path: text) in one swap.

    Files and directories that replace existing ones keep their permission bits.
    """
    directory = Path(directory).absolute()
    directory.parent.mkdir(parents=True, exist_ok=True)
    backup = directory.with_name(f".{directory.name}.old")
    with _locked(directory.parent) as locked:
        if backup.is_dir() and not directory.exists():
            backup.rename(directory)  # an earlier run was killed between the two renames
        for leftover in _leftovers(directory, locked):
            shutil.rmtree(leftover, ignore_errors=True)
        staging = directory.with_name(f".{directory.name}.{os.getpid()}.{secrets.token_hex(4)}")
        staging.mkdir()
        try:
            for path, text in files.items():
                target = staging / path
                target.parent.mkdir(parents=True, exist_ok=True)
                with open(target, "w", newline="\n") as fh:
                    fh.write(text)
                    fh.flush()
                    os.fsync(fh.fileno())  # on disk before it is swapped in
            _copy_modes(directory, staging)
            if not directory.exists():
                staging.rename(directory)
            elif not _exchange(staging, directory):
                # No exchange here: generated/ is missing between these two renames.
                directory.rename(backup)
                try:
                    staging.rename(directory)
                except BaseException:
                    backup.rename(directory)
                    raise
                staging = backup
            _fsync(directory.parent)
        finally:
            shutil.rmtree(staging, ignore_errors=True)  # the old tree, or a failed new one


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m derive", description=__doc__)
    parser.add_argument(
        "--check", action="store_true", help="fail if generated/ differs from the derivation"
    )
    parser.add_argument(
        "--out",
        type=Path,
        help="the directory to write (default: the package's generated/; with --file, required)",
    )
    parser.add_argument(
        "--model",
        choices=sorted(MODEL_NAMES),
        help="derive only this model (the others as on disk)",
    )
    parser.add_argument(
        "--file",
        type=Path,
        metavar="MODEL.py",
        help="derive the model declared in this file (yours, outside the package) into --out "
        "(required with --file) instead of generated/",
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="derive every model, also those whose inputs and files are as generated/MANIFEST "
        "records",
    )
    args = parser.parse_args(argv)
    if args.file is not None and (args.out is None or args.model):
        parser.error("--file needs --out DIR and takes no --model")
    if args.out is None:
        if not args.check and not (ROOT / "pyproject.toml").is_file():
            # An installed copy (a wheel): its generated/ is the installer's, not to rewrite.
            print(f"python -m derive: {ROOT} is an installed copy, not a source checkout: "
                  "writing generated/ needs the checkout (--check and --out DIR work here)",
                  file=sys.stderr)  # fmt: skip
            return 2
        args.out = ROOT / "generated"
    if threading.current_thread() is not threading.main_thread():
        return _run(args)
    previous = signal.signal(signal.SIGTERM, _terminated)
    try:
        return _run(args)
    finally:  # called in process (the tests): the caller's handler back
        signal.signal(signal.SIGTERM, previous)


def _run(args: argparse.Namespace) -> int:
    if args.file is not None:
        return _run_file(args)
    existing = existing_files(args.out)
    reuse = not args.force
    kept = manifest.unchanged(existing, manifest.input_digests()) if reuse else set()
    files = render_all(args.model, existing, reuse=reuse)
    skipped = [name for name in MODEL_NAMES if name in kept and args.model in (None, name)]
    unchanged = (
        f"; not derived, inputs and files as generated/{manifest.MANIFEST} records: "
        f"{', '.join(skipped)} (--force derives them)"
        if skipped
        else ""
    )
    if args.check:
        report = stale_report(files, args.out)
        if report:
            print("generated/ is stale:", file=sys.stderr)
            print("\n".join(report), file=sys.stderr)
            print(f"fix: run `{FIX_COMMAND}` and commit generated/", file=sys.stderr)
            return 1
        print(f"generated/ is up to date ({len(files)} files{unchanged})")
        return 0
    if files == existing:
        print(f"generated/ is up to date, nothing written ({len(files)} files{unchanged})")
        return 0
    write_atomically(files, args.out)
    print(f"wrote {len(files)} files to {args.out}{unchanged}")
    return 0


def _run_file(args: argparse.Namespace) -> int:
    """``--file``: derive a user's model into ``--out`` (``--check``: compare with it)."""
    if not args.file.is_file():
        print(f"python -m derive: model file {args.file} does not exist", file=sys.stderr)
        return 2
    out = args.out
    if not args.check and out.exists() and not (out / FILE_MARKER).is_file():
        if not out.is_dir() or any(out.iterdir()):
            print(f"python -m derive: --out {out} exists and holds no earlier output of "
                  "--file (writing replaces the whole directory): name a new or empty one",
                  file=sys.stderr)  # fmt: skip
            return 2
    try:
        files = render_model_file(args.file)
    except SystemExit as exc:  # the model file exited: its code, one line
        print(f"python -m derive: model file {args.file} exited ({exc.code})", file=sys.stderr)
        return 1
    except ModelFileError as exc:
        print(f"python -m derive: {exc}", file=sys.stderr)
        return 1
    except Exception as exc:  # the user's file or its declaration: one line, not a traceback
        where = f"{type(exc).__name__}: {exc}".splitlines()[0]
        print(f"python -m derive: model file {args.file}: {where}", file=sys.stderr)
        return 1
    if args.check:
        report = stale_report(files, args.out)
        if report:
            print(f"{args.out} is stale:", file=sys.stderr)
            print("\n".join(report), file=sys.stderr)
            print(f"fix: run `python -m derive --file {args.file} --out {args.out}`",
                  file=sys.stderr)  # fmt: skip
            return 1
        print(f"{args.out} is up to date ({len(files)} files)")
        return 0
    write_atomically(files, args.out)
    print(f"wrote {len(files)} files to {args.out}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except KeyboardInterrupt:  # the workers are already stopped (_map_in_workers)
        print("python -m derive: interrupted", file=sys.stderr)
        sys.exit(130)
