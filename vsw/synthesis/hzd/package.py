"""A constraints file's generated package: derived in a subprocess, cached, loaded.

``vsw hzd --constraints FILE.py`` names a file of virtual constraints in the language of
:mod:`derive.hzd`. Its package is written by ``python -m derive.hzd`` in a process of its
own (the runtime never imports sympy) into ``$VSW_CACHE_DIR/hzd/<stem>-<key>/`` (default
``~/.cache/vsw``), keyed by the SHA-256 of the file with the engine as a model file's is
(:func:`derive.manifest.model_file_digest`), of ``derive/hzd.py`` and of the model's
generated package; the next run loads it. The package's files are recorded with their
SHA-256 beside it and checked at every load: a damaged one is derived again.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from types import ModuleType

from vsw.dynamics.compiled import cache_dir, exclusive_lock, write_durably
from vsw.runtime.errors import VswInputError

__all__ = ["DERIVE_TIMEOUT", "constraints_package"]

DERIVE_TIMEOUT = 600.0
"""Seconds the constraints' derivation may take before it is stopped."""


def _digest(paths: list[Path], extra: str) -> str:
    h = hashlib.sha256(extra.encode())
    for path in paths:
        h.update(path.read_bytes())
    return h.hexdigest()


def _files(root: Path) -> dict[str, str]:
    return {
        p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*.py"))
        if "__pycache__" not in p.parts
    }


def constraints_package(path: str | Path, model_key: str, model_module: ModuleType) -> ModuleType:
    """The generated package of the constraints file ``path`` for the model ``model_key``
    (a built-in model's name or a model file's path), derived first if not cached."""
    text = str(path).strip()
    file = Path(text).expanduser().resolve()
    if not text.endswith(".py"):
        raise VswInputError(f"constraints file {text} must be a Python file (.py)")
    if not file.is_file():
        raise VswInputError(f"constraints file {text} does not exist or is not a file")
    found = importlib.util.find_spec("derive")  # located, not imported (it imports sympy)
    if found is None or found.origin is None:
        raise VswInputError("the derivation engine (derive/) is not installed")
    engine = Path(found.origin).parent / "hzd.py"
    # The engine's digest as a model file's (derive.manifest: its printers, templates and
    # pinned versions, without importing sympy), with derive/hzd.py and the model's package.
    from derive.manifest import model_file_digest

    key = _digest([engine, Path(model_module.__file__)],
                  f"{model_key}\0{model_file_digest(file)}")[:16]  # fmt: skip
    root = cache_dir() / "hzd" / f"{file.stem}-{key}"
    seal = root.with_name(root.name + ".sha256.json")
    root.parent.mkdir(parents=True, exist_ok=True)
    with exclusive_lock(root):
        if not (root.is_dir() and seal.is_file() and _sealed(root, seal)):
            _derive(file, model_key, root, engine.parent.parent)
            write_durably(seal, json.dumps(_files(root), sort_keys=True).encode())
        try:
            return _import(root / "hzd_constraints", key)
        except Exception as exc:  # sealed yet not loading (bytecode damaged): derive again
            reason = f"{type(exc).__name__}: {exc}".splitlines()[0]
            print(f"vsw: the cached constraints package {root} does not load ({reason}): "
                  "deriving it again", file=sys.stderr)  # fmt: skip
            shutil.rmtree(root, ignore_errors=True)
            _derive(file, model_key, root, engine.parent.parent)
            write_durably(seal, json.dumps(_files(root), sort_keys=True).encode())
            try:
                return _import(root / "hzd_constraints", key)
            except Exception as again:
                where = f"{type(again).__name__}: {again}".splitlines()[0]
                raise VswInputError(f"constraints {file.name}: its package does not load "
                                    f"({where})") from None  # fmt: skip


def _sealed(root: Path, seal: Path) -> bool:
    try:
        return json.loads(seal.read_text()) == _files(root)
    except (OSError, ValueError):
        return False


def _derive(file: Path, model_key: str, root: Path, home: Path) -> None:
    """``python -P -m derive.hzd`` with the engine the runtime found (``home``) first on
    its path: the working directory cannot stand in for it."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(home), *filter(None, [os.environ.get("PYTHONPATH")])])}  # fmt: skip
    command = [sys.executable, "-P", "-m", "derive.hzd", "--model", model_key,
               "--constraints", str(file), "--out", str(root)]  # fmt: skip
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=DERIVE_TIMEOUT,
                              env=env)  # fmt: skip
    except subprocess.TimeoutExpired:
        raise VswInputError(
            f"deriving {file} took more than {DERIVE_TIMEOUT:g} s and was stopped"
        ) from None
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines() or ["no message"]
        raise VswInputError(f"constraints {file.name}: "
                            f"{lines[-1].removeprefix('python -m derive.hzd: ')}")  # fmt: skip


def _import(directory: Path, key: str) -> ModuleType:
    name = f"vsw_hzd_constraints_{key}"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, directory / "__init__.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    if not isinstance(getattr(module, "HZD", None), dict):
        raise ImportError("it declares no constraints (HZD)")
    sys.modules[name] = module
    return module
