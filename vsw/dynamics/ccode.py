"""Compile and call a model's generated C99 library (``generated/<model>/c/<model>.c``)
through ctypes.

Used by the tests (C against numpy against CasADi) and the benchmarks. A robot controller
would instead compile ``<model>.c`` into its own firmware; the functions follow CasADi's C
calling convention (see ``<model>.h``) and are named ``vsw_<model>_<function>``.

Examples
--------
>>> lib = CLibrary.build()                                  # doctest: +SKIP
>>> lib.call("q_fixed", 0.8, 0.0, 0.7853981633974483)      # doctest: +SKIP
array([0.46519642])
>>> wheel = CLibrary.build(model="rimless_wheel")          # doctest: +SKIP
>>> wheel.call("eigenvalue", 0.39, 0.08, 1.0, 9.81)         # doctest: +SKIP
array([0.50539806])
"""

from __future__ import annotations

import ctypes
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from vsw.runtime.errors import VswInputError

GENERATED = Path(__file__).resolve().parents[2] / "generated"

_int = ctypes.c_longlong
_real = ctypes.c_double


class CLibrary:
    """A compiled copy of the generated C code, loaded with ctypes."""

    def __init__(self, path: Path, model: str):
        self.path = Path(path)
        self.model = model
        self.prefix = f"vsw_{model}_"
        self._lib = ctypes.CDLL(str(self.path))
        self._functions: dict[str, tuple] = {}

    @classmethod
    def build(
        cls, build_dir: Path | None = None, compiler: str | None = None, model: str = "ile"
    ) -> CLibrary:
        """Compile ``generated/<model>/c/<model>.c`` with the system C compiler (C99, -O2,
        -Werror).

        Raises
        ------
        VswInputError
            If the model has no C library, no C compiler is found or the compilation fails.
        """
        source = GENERATED / model / "c" / f"{model}.c"
        shown = f"generated/{model}/c/{model}.c"
        if not source.is_file():
            raise VswInputError(f"model {model!r} has no C library ({shown} does not exist)")
        cc = compiler or shutil.which("cc") or shutil.which("gcc")
        if cc is None:
            raise VswInputError(f"no C compiler found (cc or gcc) to build {shown}")
        out_dir = Path(build_dir or tempfile.mkdtemp(prefix="vsw_c_"))
        out_dir.mkdir(parents=True, exist_ok=True)
        library = out_dir / f"libvsw_{model}.so"
        command = [
            cc, "-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror",
            "-Wno-unused-parameter", "-o", str(library), str(source), "-lm",
        ]  # fmt: skip
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            first = (done.stderr.strip().splitlines() or ["unknown error"])[0]
            raise VswInputError(f"compiling {shown} failed: {first}")
        return cls(library, model)

    def functions(self) -> tuple[str, ...]:
        """Names (without the prefix) of the functions the model's C header declares."""
        header = (GENERATED / self.model / "c" / f"{self.model}.h").read_text()
        pattern = rf"^int {re.escape(self.prefix)}(\w+)\(const casadi_real\*\* arg"
        return tuple(re.findall(pattern, header, flags=re.MULTILINE))

    def arguments(self, name: str) -> tuple[str, ...]:
        """Argument names of ``vsw_<model>_<name>``, as the library reports them."""
        n_in = self._function(name)[2]
        name_in = getattr(self._lib, f"{self.prefix}{name}_name_in")
        name_in.restype = ctypes.c_char_p
        name_in.argtypes = [_int]
        return tuple(name_in(i).decode() for i in range(n_in))

    def _function(self, name: str):
        if name not in self._functions:
            full = self.prefix + name
            if not hasattr(self._lib, full):
                raise VswInputError(f"{full} is not in the C library of {self.model}")
            fn = getattr(self._lib, full)
            fn.restype = ctypes.c_int
            work = getattr(self._lib, full + "_work")
            sizes = [_int() for _ in range(4)]
            work(*[ctypes.byref(s) for s in sizes])
            n_in = getattr(self._lib, full + "_n_in")
            n_in.restype = _int
            sparsity_out = getattr(self._lib, full + "_sparsity_out")
            sparsity_out.restype = ctypes.POINTER(_int)
            n_out = sparsity_out(0)[0]  # dense column vector: (rows, cols, ...)
            self._functions[name] = (fn, [s.value for s in sizes], int(n_in()), int(n_out))
        return self._functions[name]

    def call(self, name: str, *args: float) -> np.ndarray:
        """Evaluate generated C function ``vsw_<model>_<name>`` at scalar arguments.

        Returns
        -------
        numpy.ndarray, shape (n_out,)
        """
        fn, (sz_arg, sz_res, sz_iw, sz_w), n_in, n_out = self._function(name)
        if len(args) != n_in:
            raise VswInputError(f"{self.prefix}{name} takes {n_in} arguments, got {len(args)}")
        inputs = [_real(float(a)) for a in args]
        output = (_real * n_out)()
        arg = (ctypes.POINTER(_real) * max(sz_arg, n_in))(*[ctypes.pointer(x) for x in inputs])
        res = (ctypes.POINTER(_real) * max(sz_res, 1))(ctypes.cast(output, ctypes.POINTER(_real)))
        iw = (_int * max(sz_iw, 1))()
        w = (_real * max(sz_w, 1))()
        status = fn(arg, res, iw, w, 0)
        if status != 0:
            raise RuntimeError(f"{self.prefix}{name} returned status {status}")
        return np.array(output[:], dtype=float)
