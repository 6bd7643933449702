"""Compiled batch kernels: the generated C loops of ``generated/ile/c/ile_batch.c`` via ctypes.

``python -m derive`` writes vectorisable C loops for a few quantities from the same
derivation as the numpy and CasADi code. At first use they are compiled with the system C
compiler for this machine (``-O3 -march=native -fopenmp-simd``, glibc's vector libm when
present) into a cache directory (``VSW_CACHE_DIR``, default ``~/.cache/vsw``), keyed by a
hash of the source, the flags, the compiler and the CPU. ``$CC`` may hold a command with
arguments (``ccache gcc``, ``gcc -O0``): it is split into words as the shell splits it for
make. Without a compiler, or with ``VSW_KERNELS=0``, every function here falls back to the
generated numpy code, so results never depend on a compiler being present, only their last
bits do (tests/test_kernels.py bounds the difference to 1e-12 relative on walking sets,
1e-11 over the domain).

A cached library is loaded only after its size and SHA-256 match the sidecar
``<library>.json`` written beside it once the library was complete on disk: a truncated
library would be mapped and kill the process with SIGBUS at first use, and an empty or
damaged one would fail to load. Either is rebuilt, with the same flags. Builds write to a
temporary file, fsync it and publish library then sidecar with atomic renames, under a
lock per library, so concurrent processes neither clash nor load a half-written file.

Each block of the loop is one ctypes call, which releases the GIL: blocks run in parallel
on :func:`vsw.vectorize.run_blocks`. benchmarks/run.py, case 1, measures it.

Examples
--------
>>> import numpy as np
>>> q_f, eigenvalue, *margins = fixed_point_conditions(np.full(3, 0.8), 0.0, np.pi / 4)
>>> [round(float(v), 9) for v in q_f]
[0.465196423, 0.465196423, 0.465196423]
"""

from __future__ import annotations

import contextlib
import ctypes
import hashlib
import json
import os
import platform
import shlex
import shutil
import subprocess
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from generated import ile
from vsw.vectorize import CHUNK, chunked, default_threads, run_blocks

SOURCE = Path(__file__).resolve().parent.parent / "generated" / "ile" / "c" / "ile_batch.c"
N_OUTPUTS = 2 + len(ile.CONDITIONS)

# Tried in order: vectorised with glibc's libmvec, then plain optimised C.
_FLAG_SETS = (
    ["-O3", "-march=native", "-fno-math-errno", "-fopenmp-simd", "-lmvec", "-lm"],
    ["-O3", "-fno-math-errno", "-lm"],
)

_lock = threading.Lock()
_library: ctypes.CDLL | None = None
_tried = False
build_error: str | None = None
"""Why the kernels are not available (None while they are, or before the first use)."""
library_path: Path | None = None
"""The cached library in use (None while the kernels are unavailable or not yet built)."""

_STALE_BUILD_SECONDS = 3600.0
"""Build files older than this (``.build-*``) were left by killed builds and are removed."""


def _cache_dir() -> Path:
    return Path(os.environ.get("VSW_CACHE_DIR") or Path.home() / ".cache" / "vsw")


def _cpu_signature() -> str:
    # -march=native code must not be loaded on another CPU sharing the cache directory.
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith(("flags", "Features")):
                return line
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _compiler() -> list[str]:
    """The C compiler command as words: ``$CC`` split as the shell splits it, else cc/gcc."""
    cc = os.environ.get("CC", "").strip()
    if cc:
        try:
            words = shlex.split(cc)
        except ValueError as exc:
            raise OSError(f"CC={cc!r} is not a command: {exc}") from None
        if words:
            return words
    found = shutil.which("cc") or shutil.which("gcc")
    if found is None:
        raise OSError("no C compiler (cc, gcc or $CC)")
    return [found]


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _sidecar(library: Path) -> Path:
    return library.with_name(library.name + ".json")


def _verified(library: Path, key: str) -> bool:
    """Whether ``library`` is complete: its size and SHA-256 are those its sidecar records."""
    try:
        record = json.loads(_sidecar(library).read_text())
        if record.get("key") != key or library.stat().st_size != record.get("size"):
            return False
        return _digest(library.read_bytes()) == record.get("sha256")
    except (OSError, ValueError, AttributeError):
        return False


def _write_durably(path: Path, data: bytes) -> None:
    """``path`` holds ``data`` completely, or keeps what it held (temporary file, fsync,
    atomic rename)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".build-")
    try:
        os.fchmod(fd, 0o644)  # as the compiler's output under the usual umask, not 0600
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def _build_lock(library: Path) -> Iterator[None]:
    """Exclusive lock for building ``library`` (released when the process dies)."""
    try:
        import fcntl

        fd = os.open(library.with_name(library.name + ".lock"), os.O_RDWR | os.O_CREAT, 0o644)
    except (ImportError, OSError):
        yield  # no locking here: concurrent builds still publish complete files
        return
    try:
        with contextlib.suppress(OSError):
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def _remove_stale_builds(directory: Path) -> None:
    """Build directories and files of killed builds (``tempfile`` leaves them on SIGKILL)."""
    now = time.time()
    for old in directory.glob(".build-*"):
        with contextlib.suppress(OSError):
            if now - old.lstat().st_mtime > _STALE_BUILD_SECONDS:
                if old.is_dir():
                    shutil.rmtree(old, ignore_errors=True)
                else:
                    old.unlink()


def _compile(
    cc: list[str], flags: list[str], library: Path, key: str, source: bytes, includes: tuple = ()
) -> str | None:
    """Build ``library`` from the C text ``source`` (``#include`` searched in ``includes``)
    and its sidecar; the compiler's first error line when it fails."""
    with tempfile.TemporaryDirectory(dir=library.parent, prefix=".build-") as tmp:
        built = Path(tmp) / library.name
        source_file = Path(tmp) / (library.stem + ".c")
        source_file.write_bytes(source)
        include_flags = [f"-I{d}" for d in includes]
        command = [
            *cc, "-std=c99", "-shared", "-fPIC", *include_flags, "-o", str(built),
            str(source_file), *flags,
        ]  # fmt: skip
        try:
            done = subprocess.run(command, capture_output=True, text=True)
        except OSError as exc:  # the compiler named in $CC does not run
            return str(exc)
        if done.returncode != 0:
            return (done.stderr.strip().splitlines() or ["failed"])[0]
        data = built.read_bytes()
    _write_durably(library, data)
    record = {"key": key, "size": len(data), "sha256": _digest(data)}
    _write_durably(_sidecar(library), json.dumps(record, sort_keys=True).encode())
    return None


def _build() -> tuple[ctypes.CDLL, Path]:
    return build_library(SOURCE.read_bytes(), "ile_batch", _FLAG_SETS)


def build_library(
    source: bytes, stem: str, flag_sets: tuple[list[str], ...], includes: tuple = ()
) -> tuple[ctypes.CDLL, Path]:
    """Compile the C text ``source`` into the cache as ``libvsw_<stem>_<key>.so`` (the first
    of ``flag_sets`` that builds and loads) and load it; a verified cached copy is loaded
    without compiling. ``includes``: directories searched by ``#include``, whose files'
    contents enter the key.

    Raises
    ------
    OSError
        No compiler, or every flag set failed (their first error lines).
    """
    cc = _compiler()
    directory = _cache_dir()
    directory.mkdir(parents=True, exist_ok=True)
    _remove_stale_builds(directory)
    included = [
        path.read_bytes() for d in includes for path in sorted(Path(d).iterdir()) if path.is_file()
    ]
    errors = []
    for flags in flag_sets:
        parts = [source, *included, " ".join(flags).encode(), shlex.join(cc).encode()]
        key = hashlib.sha256(b"\0".join([*parts, _cpu_signature().encode()])).hexdigest()[:20]
        library = directory / f"libvsw_{stem}_{key}.so"
        with _build_lock(library):
            # Never map unverified bytes: a truncated library gives SIGBUS, not an error.
            if not _verified(library, key):
                error = _compile(cc, flags, library, key, source, includes)
                if error is not None:
                    errors.append(error)
                    continue
            try:
                return ctypes.CDLL(str(library)), library
            except OSError as exc:
                errors.append(str(exc))
    raise OSError("; ".join(errors))


def library() -> ctypes.CDLL | None:
    """The compiled kernels, built on first call; None when unavailable (see build_error)."""
    global _library, _tried, build_error, library_path
    if os.environ.get("VSW_KERNELS", "1").strip() == "0":
        return None
    with _lock:
        if not _tried:
            _tried = True
            try:
                lib, path = _build()
                fn = lib.vsw_ile_fixed_point_conditions_batch
                fn.restype = None
                pointer = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
                fn.argtypes = [ctypes.c_longlong, pointer, pointer, pointer, pointer]
                _library, library_path = lib, path
            except (OSError, AttributeError) as exc:
                build_error = f"compiled kernels unavailable, using numpy: {exc}"
        return _library


def fixed_point_conditions(
    beta, theta_II, phi0, *, threads: int | None = None
) -> tuple[np.ndarray, ...]:
    """q^f, eigenvalue and every condition margin, as ``generated.ile.fixed_point_conditions``.

    Eq. (10), (19), (12)-(17). Compiled C when available, else the generated numpy code.

    Parameters
    ----------
    beta, theta_II, phi0 : float or array_like
        Broadcastable parameters (radians), shape ``S`` after broadcasting.
    threads : int, optional
        Blocks in parallel; default :func:`vsw.vectorize.default_threads`.

    Returns
    -------
    tuple of numpy.ndarray
        ``(q_f, eigenvalue, *margins)`` in the order of ``ile.CONDITIONS``, each of shape
        ``S``.
    """
    # VSW_THREADS is checked whatever the size, as by every blockwise entry point.
    threads = default_threads() if threads is None else threads
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (beta, theta_II, phi0)))
    shape = arrays[0].shape
    lib = library()
    if lib is None:
        with np.errstate(all="ignore"):
            return chunked(ile.fixed_point_conditions, *arrays, threads=threads)
    flat = [np.ascontiguousarray(a).reshape(-1) for a in arrays]
    n = flat[0].size
    out = np.empty((N_OUTPUTS, n))
    fn = lib.vsw_ile_fixed_point_conditions_batch

    def block(start: int) -> None:
        stop = min(start + CHUNK, n)
        part = np.empty((N_OUTPUTS, stop - start))
        fn(stop - start, *(a[start:stop] for a in flat), part)
        out[:, start:stop] = part

    if n > 0:
        if n <= CHUNK:
            fn(n, *flat, out)
        else:
            run_blocks(block, range(0, n, CHUNK), threads)
    return tuple(row.reshape(shape) for row in out)
