"""Compiled C libraries of the runtime, built once per machine into a verified cache.

The ILE's batch kernels (:mod:`vsw.models.ile.kernels`) and the batch simulator
(:mod:`vsw.dynamics.batch`) are C text: at first use it is compiled with the system C compiler for
this machine into a cache directory (``VSW_CACHE_DIR``, default ``~/.cache/vsw``), keyed by a
hash of the source, the flags, the compiler and the CPU. ``$CC`` may hold a command with
arguments (``ccache gcc``, ``gcc -O0``): it is split into words as the shell splits it for
make.

A cached library is loaded only after its size and SHA-256 match the sidecar
``<library>.json`` written beside it once the library was complete on disk: a truncated
library would be mapped and kill the process with SIGBUS at first use, and an empty or
damaged one would fail to load. Either is rebuilt, with the same flags. The sidecar
vouches for what the build wrote, not against tampering: whoever can write the cache can
write a matching sidecar. Truncation, the one damage that would kill the process rather
than fail the load, is also caught without the sidecar: an ELF library whose segments or
section table end beyond the file is rebuilt (:func:`_elf_complete`). Builds write to a
temporary file, fsync it and publish library then sidecar with atomic renames, under a
lock per library, so concurrent processes neither clash nor load a half-written file.
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
import struct
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

__all__ = ["build_library", "cache_dir", "exclusive_lock", "write_durably"]

_STALE_BUILD_SECONDS = 3600.0
"""Build files older than this (``.build-*``) were left by killed builds and are removed."""


def cache_dir() -> Path:
    """Where vsw caches what it builds: ``$VSW_CACHE_DIR``, default ``~/.cache/vsw``."""
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
        data = library.read_bytes()
        return _digest(data) == record.get("sha256") and _elf_complete(data)
    except (OSError, ValueError, AttributeError):
        return False


_PT_LOAD = 1  # elf.h


def _elf_complete(data: bytes) -> bool:
    """Whether an ELF file's loadable segments and section header table lie within it
    (mapping a segment past the end of the file is what raises SIGBUS); True for a file
    that is not ELF (other systems' libraries: the sidecar alone vouches for them)."""
    if data[:4] != b"\x7fELF":
        return True
    if len(data) < 64 or data[4] not in (1, 2) or data[5] not in (1, 2):
        return False
    wide, order = data[4] == 2, "<" if data[5] == 1 else ">"
    if wide:
        (phoff, shoff) = struct.unpack_from(order + "QQ", data, 0x20)
        phentsize, phnum, shentsize, shnum = struct.unpack_from(order + "HHHH", data, 0x36)
        segment = order + "IIQQQQ"  # p_type, p_flags, p_offset, p_vaddr, p_paddr, p_filesz
    else:
        (phoff, shoff) = struct.unpack_from(order + "II", data, 0x1C)
        phentsize, phnum, shentsize, shnum = struct.unpack_from(order + "HHHH", data, 0x2A)
        segment = order + "IIIII"  # p_type, p_offset, p_vaddr, p_paddr, p_filesz
    size = len(data)
    if phoff + phnum * phentsize > size or shoff + shnum * shentsize > size:
        return False
    for k in range(phnum):
        fields = struct.unpack_from(segment, data, phoff + k * phentsize)
        if fields[0] != _PT_LOAD:
            continue
        offset, filesz = (fields[2], fields[5]) if wide else (fields[1], fields[4])
        if offset + filesz > size:
            return False
    return True


def write_durably(path: Path, data: bytes) -> None:
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
def exclusive_lock(path: Path) -> Iterator[None]:
    """Exclusive lock for making ``path`` (a library, a cached package), held on
    ``<path>.lock`` and released when the process dies; where no lock can be taken the
    block runs unlocked (the writers publish complete files all the same)."""
    try:
        import fcntl

        fd = os.open(path.with_name(path.name + ".lock"), os.O_RDWR | os.O_CREAT, 0o644)
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
    write_durably(library, data)
    record = {"key": key, "size": len(data), "sha256": _digest(data)}
    write_durably(_sidecar(library), json.dumps(record, sort_keys=True).encode())
    return None


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
    directory = cache_dir()
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
        with exclusive_lock(library):
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
