"""The runtime's layers: each package of ``vsw/`` imports only the packages below it
(``vsw/__init__.py`` lists them, lowest first), imports inside functions included, and no
two modules import each other, directly or around a circle.

A layer that reached up would let a change at the top break the bottom: the periodic-orbit
problem (:mod:`vsw.orbits`) must keep working whatever the commands do with it.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

LAYERS = ("runtime", "orbits", "dynamics", "plots", "gaits", "synthesis", "models", "studies",
          "cli")  # fmt: skip
"""The packages of ``vsw/``, lowest first."""


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {
        module_name(path): path
        for path in sorted((ROOT / "vsw").rglob("*.py"))
        if "__pycache__" not in path.parts
    }


def _type_checking_only(tree: ast.AST) -> set[ast.AST]:
    """The import statements under ``if TYPE_CHECKING:``: annotations, not run."""
    return {node for block in ast.walk(tree)
            if isinstance(block, ast.If) and ast.unparse(block.test).endswith("TYPE_CHECKING")
            for statement in block.body for node in ast.walk(statement)}  # fmt: skip


def imported(path: Path, known: dict[str, Path]) -> set[str]:
    """The modules of ``vsw`` that ``path`` imports anywhere in it, inside functions too (a
    name imported from a package counts as its module where it is one)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skipped = _type_checking_only(tree)
    out: set[str] = set()
    for node in ast.walk(tree):
        if node in skipped:
            continue
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.split(".")[0] == "vsw")
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] != "vsw":
                continue
            submodules = {f"{node.module}.{a.name}" for a in node.names} & known.keys()
            out.update(submodules or {node.module})
    return {name for name in out if name in known}


def layer(module: str) -> int:
    """A module's layer's rank: ``vsw`` itself (its docstring and ``__version__``) below
    every layer, ``vsw.__main__`` above them all."""
    if module == "vsw":
        return -1
    parts = module.split(".")
    return LAYERS.index(parts[1]) if parts[1] in LAYERS else len(LAYERS)


def graph() -> dict[str, set[str]]:
    known = modules()
    return {name: imported(path, known) - {name} for name, path in known.items()}


def upward_imports(edges: dict[str, set[str]]) -> list[str]:
    return sorted(f"{a} -> {b}" for a, targets in edges.items() for b in targets
                  if layer(b) > layer(a))  # fmt: skip


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in edges.get(node, ()):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(edges):
        if node not in index:
            visit(node)
    return found


def is_package_face(module: str) -> bool:
    return (ROOT / module.replace(".", "/") / "__init__.py").is_file()


def test_every_package_of_vsw_is_a_layer():
    packages = sorted(p.name for p in (ROOT / "vsw").iterdir()
                      if (p / "__init__.py").is_file())  # fmt: skip
    assert packages == sorted(LAYERS)


def test_no_layer_imports_a_layer_above_it():
    assert upward_imports(graph()) == []


def test_the_package_face_imports_nothing():
    """``vsw/__init__.py`` is the bottom: every layer may read ``vsw.__version__``."""
    assert graph()["vsw"] == set()


def test_no_modules_import_each_other():
    edges = graph()
    # A package's __init__ that gathers its modules' names is imported by them only through
    # the package path; an edge module -> its own package's face is not a dependency.
    for name in edges:
        edges[name] = {t for t in edges[name]
                       if not (is_package_face(t) and name.startswith(t + "."))}  # fmt: skip
    assert circles(edges) == []


def test_the_rules_see_what_they_look_for():
    """The checks catch a planted upward import and a planted circle."""
    edges = {"vsw.runtime.stop": {"vsw.cli.app"}, "vsw.cli.app": set()}
    assert upward_imports(edges) == ["vsw.runtime.stop -> vsw.cli.app"]
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert layer("vsw.orbits.newton") < layer("vsw.dynamics.hybrid") < layer("vsw.cli.app")
