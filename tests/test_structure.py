"""The packages' shape: no module of vsw/ or derive/ over MODULE_LINES lines, no function
over FUNCTION_LINES, and no module using another's private names (``from vsw.x import
_name``, ``x._name``): a long module or function is read by scrolling, and a private name
used elsewhere is an interface nobody declared. The runtime keeps every rule; the
derivation's exceptions are listed.

Each rule is a ratchet: the modules, functions and private uses that break it are listed
below with their sizes as ceilings. A listed one may shrink (and must leave the list once
it keeps the rule); nothing may grow past its ceiling, and nothing unlisted may break a
rule.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = (ROOT / "vsw", ROOT / "derive")
"""The runtime and the derivation (generated/ is written by the latter and not read here)."""

MODULE_LINES = 800
FUNCTION_LINES = 80

LONG_MODULES: dict[str, int] = {}
"""The modules over MODULE_LINES lines, each with its ceiling."""

LONG_FUNCTIONS: dict[str, int] = {}
"""The functions over FUNCTION_LINES lines (``module::qualified name``), each with its
ceiling (its ``def`` line to its last, decorators not counted)."""

PRIVATE_USES: dict[str, int] = {}
"""Private names used across modules (``module -> vsw.other._name``), each with how many
times it is used there."""


def modules() -> Iterator[tuple[str, Path]]:
    """Every Python module of the packages, by its path from the repository's root."""
    for path in sorted(p for package in PACKAGES for p in package.rglob("*.py")):
        if "__pycache__" not in path.parts:
            yield path.relative_to(ROOT).as_posix(), path


def module_name(relative: str) -> str:
    """``vsw/orbits/newton.py`` -> ``vsw.orbits.newton`` (a package by its ``__init__``)."""
    parts = relative.removesuffix(".py").split("/")
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def module_sizes() -> dict[str, int]:
    return {rel: len(path.read_text(encoding="utf-8").splitlines()) for rel, path in modules()}


def function_sizes(tree: ast.AST) -> Iterator[tuple[str, int]]:
    """Each function's and method's qualified name (``Class.method``, ``outer.inner``) and
    its lines, nested ones too."""

    def walk(node: ast.AST, prefix: str) -> Iterator[tuple[str, int]]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                yield name, child.end_lineno - child.lineno + 1
                yield from walk(child, f"{name}.")
            elif isinstance(child, ast.ClassDef):
                yield from walk(child, f"{prefix}{child.name}.")
            else:
                yield from walk(child, prefix)

    yield from walk(tree, "")


def long_functions() -> dict[str, int]:
    out: dict[str, int] = {}
    for rel, path in modules():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for name, size in function_sizes(tree):
            if size > FUNCTION_LINES:
                key = f"{rel}::{name}"
                out[key] = max(size, out.get(key, 0))
    return out


PREFIXES = ("vsw", "derive")


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_uses() -> dict[str, int]:
    """``module -> vsw.other._name`` and its count, for each private name of another vsw
    module a module imports (``from vsw.other import _name``) or reads as an attribute of
    a module it imported (``other._name`` after ``from vsw import other``, ``import
    vsw.other as other``)."""
    known = {module_name(rel) for rel, _ in modules()}
    out: dict[str, int] = {}
    for rel, path in modules():
        here = module_name(rel)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bound: dict[str, str] = {}  # local name -> the vsw module it is
        found: list[str] = []
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name in known and alias.asname:
                        bound[alias.asname] = alias.name
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith(PREFIXES):
                for alias in node.names:
                    full = f"{node.module}.{alias.name}"
                    if full in known:
                        bound[alias.asname or alias.name] = full
                    elif _private(alias.name) and node.module != here:
                        found.append(full)
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute)
                and isinstance(node.value, ast.Name)
                and node.value.id in bound
                and bound[node.value.id] != here
                and _private(node.attr)
            ):
                found.append(f"{bound[node.value.id]}.{node.attr}")
        for use in found:
            key = f"{rel} -> {use}"
            out[key] = out.get(key, 0) + 1
    return out


def _ratchet(found: dict[str, int], listed: dict[str, int], limit: str) -> list[str]:
    """What breaks the ratchet: an offender not listed, one past its ceiling, or one listed that
    keeps the rule (to be taken off the list)."""
    problems = [
        f"{k}: {v} (not listed; the limit is {limit})" for k, v in found.items() if k not in listed
    ]
    problems += [
        f"{k}: {found[k]} (its ceiling is {v})" for k, v in listed.items() if found.get(k, 0) > v
    ]
    problems += [f"{k}: keeps the rule: take it off the list" for k in listed if k not in found]
    return problems


def test_no_module_grows_past_its_ceiling():
    long = {k: v for k, v in module_sizes().items() if v > MODULE_LINES}
    assert not _ratchet(long, LONG_MODULES, f"{MODULE_LINES} lines")


def test_no_function_grows_past_its_ceiling():
    assert not _ratchet(long_functions(), LONG_FUNCTIONS, f"{FUNCTION_LINES} lines")


def test_no_module_uses_another_modules_private_names():
    assert not _ratchet(private_uses(), PRIVATE_USES, "none")


def test_the_rules_see_what_they_look_for():
    """Each rule on a sample: a long function, nested names, and private uses both ways."""
    source = "def f():\n" + "    x = 1\n" * 90 + "    def g():\n        pass\n"
    sizes = dict(function_sizes(ast.parse(source)))
    assert sizes == {"f": 93, "f.g": 2}
    listed = {"a": 100}
    assert _ratchet({"a": 100}, listed, "") == []
    assert len(_ratchet({"a": 101}, listed, "")) == 1
    assert len(_ratchet({"a": 100, "b": 90}, listed, "")) == 1
    assert len(_ratchet({}, listed, "")) == 1
    assert not _private("__init__") and _private("_ATOL") and not _private("ATOL")
