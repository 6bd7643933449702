"""CyRK's C++ DOP853 as a walker: benchmark case 15's second peer.

``walker.pyx`` beside this file walks the numba peer's models (benchmarks/peers/
numba_dop853.py: the same equations, guards, resets and rules) through CyRK's Cython API
(``cysolve_ivp_noreturn``, DOP853, its events). ``load()`` builds it with Cython and
setuptools into a cache directory (``$VSW_CACHE_DIR/peers``, default
``~/.cache/vsw/peers``) the first time, keyed by the source, the CyRK, Cython and Python
versions and the CPU, so nothing compiled is committed; later runs load the cached module.
Optional: ``pip install cyrk cython`` (the ``peers`` extra).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import platform
import shutil
import sys
import tempfile
from importlib import metadata
from pathlib import Path

SOURCE = Path(__file__).with_name("walker.pyx")
FLAGS = ["-O3", "-march=native", "-std=c++20", "-w"]
"""The peer's own functions (flows, guards, resets) as the batch simulator's C is built;
the integrator itself is CyRK's installed build (cysolve_ivp_noreturn lives in CyRK)."""


def _cache() -> Path:
    root = Path(os.environ.get("VSW_CACHE_DIR") or Path.home() / ".cache" / "vsw")
    return root / "peers"


def _cpu() -> str:
    """The CPU's model (-march=native code must not load on another CPU sharing the cache)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith(("model name", "flags")):
                return line
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _key() -> str:
    versions = [metadata.version("CyRK"), metadata.version("Cython"), sys.version, *FLAGS, _cpu()]
    text = SOURCE.read_bytes() + "\n".join(versions).encode()
    return hashlib.sha256(text).hexdigest()[:16]


def _build(name: str, target: Path) -> None:
    """Cythonize and compile walker.pyx as module ``name`` into ``target`` (a directory)."""
    import CyRK
    import numpy as np
    from Cython.Build import cythonize
    from setuptools import Distribution, Extension

    with tempfile.TemporaryDirectory(prefix="vsw_cyrk_peer_") as tmp:
        pyx = Path(tmp) / f"{name}.pyx"
        shutil.copyfile(SOURCE, pyx)
        ext = Extension(name, [str(pyx)], language="c++",
                        include_dirs=[np.get_include(), *CyRK.get_include()],
                        extra_compile_args=FLAGS)  # fmt: skip
        dist = Distribution({"name": name, "ext_modules": cythonize([ext], quiet=True)})
        cmd = dist.get_command_obj("build_ext")
        cmd.build_lib, cmd.build_temp = str(Path(tmp) / "lib"), str(Path(tmp) / "obj")
        cmd.ensure_finalized()
        cmd.run()
        (built,) = Path(cmd.build_lib).glob(f"{name}*.so")
        target.mkdir(parents=True, exist_ok=True)
        part = target / f".{built.name}.{os.getpid()}"
        shutil.copyfile(built, part)
        part.replace(target / built.name)  # atomic: a concurrent run sees all of it or none


def load():
    """The compiled peer module (built on first use); ImportError without CyRK or Cython."""
    try:
        metadata.version("CyRK")
    except metadata.PackageNotFoundError as exc:
        raise ImportError("CyRK is not installed") from exc
    name = f"vsw_cyrk_walker_{_key()}"
    if name in sys.modules:
        return sys.modules[name]
    target = _cache()
    found = list(target.glob(f"{name}*.so"))
    if not found:
        try:
            import Cython  # noqa: F401
        except ImportError as exc:
            raise ImportError("Cython is not installed") from exc
        _build(name, target)
        found = list(target.glob(f"{name}*.so"))
    spec = importlib.util.spec_from_file_location(name, found[0])
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    sys.modules[name] = module
    return module
