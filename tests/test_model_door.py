"""The model interface is the only door: a command reaches a model's own routes through
:meth:`vsw.models.base.Model.route`, never by testing its name, and a command on one model
imports nothing of another."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import generated
from vsw import models
from vsw.runtime.errors import VswInputError

ROOT = Path(__file__).resolve().parent.parent
VSW = ROOT / "vsw"

MODEL_NAMES = frozenset(generated.MODELS) | {k.replace("_", "-") for k in generated.MODELS}
"""Every built-in model's package key and command-line name."""

RUN = """
import sys
from vsw.cli import main
for argv in {argvs!r}:
    try:
        main(argv)
    except SystemExit:
        pass
print(' '.join(sorted(sys.modules)))
"""


def _imported(argvs: list[list[str]]) -> set[str]:
    """The modules loaded by running each command line in one fresh interpreter."""
    done = subprocess.run([sys.executable, "-c", RUN.format(argvs=argvs)], capture_output=True,
                          text=True, check=True, cwd=ROOT)  # fmt: skip
    return set(done.stdout.splitlines()[-1].split())


def _names_compared(source: str) -> list[tuple[int, str]]:
    """Where ``source`` compares a value to a model's name written as a literal, or calls a
    function with one (``models.load("ile")``): (line, the expression)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
        elif isinstance(node, ast.Call):
            sides = list(node.args)
        else:
            continue
        literals = {c.value for s in sides for c in ast.walk(s) if isinstance(c, ast.Constant)}
        if literals & MODEL_NAMES:
            found.append((node.lineno, ast.unparse(node)))
    return found


def _generic_modules() -> list[Path]:
    """Every module of ``vsw/`` outside a model's own package ``vsw/models/<name>/``."""
    own = {p for p in (VSW / "models").iterdir() if p.is_dir()}
    return [f for f in sorted(VSW.rglob("*.py")) if not any(d in f.parents for d in own)]


def test_the_name_detector_finds_a_test_of_a_model_name():
    """The lint below can fail: it finds the tests of a name it is meant to refuse."""
    source = ('if model.name != "ile":\n    pass\nm = models.load("compass-gait")\n'
              'ok = name in ("rimless_wheel", "x")\nfine = option == "speed"\n')  # fmt: skip
    assert [line for line, _ in _names_compared(source)] == [1, 3, 4]


def test_no_generic_module_compares_a_model_name_to_a_literal():
    modules = _generic_modules()
    assert VSW / "cli" / "design.py" in modules and VSW / "models" / "base.py" in modules
    assert not any(p.is_relative_to(VSW / "models" / "ile") for p in modules)
    found = {str(f.relative_to(ROOT)): hits for f in modules
             if (hits := _names_compared(f.read_text()))}  # fmt: skip
    assert not found, found


def test_routes_are_the_models_own():
    ile, compass = models.load("ile"), models.load("compass-gait")
    for command in ("design", "sweep", "basin"):
        assert compass.route(command) is None
        assert callable(ile.route(command))
    assert ile.route("analyze") is None and ile.route("simulate") is None


def test_robot_scale_is_a_hook_of_the_model():
    ile, compass = models.load("ile"), models.load("compass-gait")
    assert ile.robot_scale(None, None, None, False) is None
    assert ile.robot_scale(None, None, None, True).leg_length == 0.25
    assert ile.robot_scale(0.5, 2.0, None, False).gravity == 9.81
    with pytest.raises(VswInputError, match="go together"):
        ile.robot_scale(0.5, None, None, False)
    assert compass.robot_scale(None, None, None, False) is None
    with pytest.raises(VswInputError, match="no SI results"):
        compass.robot_scale(0.5, 1.0, None, False)


def test_a_command_on_another_model_loads_none_of_the_iles_modules():
    imported = _imported([
        ["analyze", "--model", "compass-gait"],
        ["sweep", "--model", "compass-gait", "--over", "gamma=0.01:0.011:2"],
        ["design", "--model", "compass-gait", "--bound", "nosuch=1:2"],
        ["basin", "--model", "compass-gait", "--grid", "theta_dot=0.5:1:2", "--grid",
         "psi_dot=0:0.1:2", "--steps", "2"],
    ])  # fmt: skip
    assert {"vsw.cli.analyze", "vsw.cli.sweep", "vsw.cli.design", "vsw.cli.basin",
            "generated.compass_gait"} <= imported  # fmt: skip
    ile = {m for m in imported if m.startswith(("vsw.models.ile", "vsw.cli.ile_", "generated.ile"))}
    assert not ile, sorted(ile)


def test_a_command_on_the_ile_loads_no_other_model():
    imported = _imported([
        ["analyze"],
        ["sweep", "--over", "theta_II=-10deg:20deg:3"],
        ["design", "--bound", "nosuch=1:2"],
        ["basin", "--n-q", "11", "--theta-step", "10"],
    ])  # fmt: skip
    assert {"vsw.cli.ile_sweep", "vsw.cli.ile_design", "vsw.cli.ile_basin",
            "vsw.models.ile.model"} <= imported  # fmt: skip
    others = {m for m in imported if m.startswith("generated.")} - {
        "generated._backend", "generated.ile", "generated.ile.params"}  # fmt: skip
    assert not others, sorted(others)


def test_architecture_says_the_cli_routes_by_the_model():
    text = (ROOT / "docs" / "architecture.md").read_text()
    assert "`Model.routes` names the commands" in text
    assert "no module outside `vsw/models/<name>/` tests a model's name" in text
