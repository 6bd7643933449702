"""The README's tour: every command it shows exits 0 and prints the lines shown, in order.

The README shows excerpts of each output (the lines a reader needs), so a shown line must
appear among the printed ones in the same order, not as a contiguous block; the tutorials
(tests/test_docs_site.py) check whole outputs. The last example, a user's model file,
names a path of the reader's and a derivation time of their machine: the own-model
tutorial runs the same steps on a file of its own.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.test_docs_site import Command, commands, line_matches, run_vsw

pytestmark = pytest.mark.slow  # an IPOPT design, a powered gait, a continuation to period 8

README = Path(__file__).resolve().parent.parent / "README.md"


def shown_in_order(shown: list[str], printed: list[str]) -> bool:
    """Whether every line of ``shown`` is a line of ``printed`` (trailing blanks aside), in
    the same order; ``...`` inside a shown line stands for any text (a round-off-sized
    number), as in the tutorials."""
    lines = iter(line.rstrip() for line in printed)
    return all(any(line_matches(want.rstrip(), line) for line in lines) for want in shown)


def test_shown_in_order_needs_every_line_in_its_order():
    assert shown_in_order(["a", "c"], ["a", "b", "c  "])
    assert not shown_in_order(["c", "a"], ["a", "b", "c"])
    assert not shown_in_order(["a", "d"], ["a", "b", "c"])
    assert shown_in_order(["balance ... J"], ["balance -5.6e-12 J"])
    assert not shown_in_order(["balance ... J"], ["balance -5.6e-12 kg"])


def _tour() -> list[Command]:
    return [c for c in commands(README) if not any("path/to/" in a for a in c.args)]


def test_the_readme_tours_the_commands_it_claims():
    names = [c.args[0] for c in _tour()]
    for command in ("analyze", "simulate", "basin", "continue", "design", "optimize"):
        assert command in names, f"the README's tour lost 'vsw {command}'"


@pytest.mark.parametrize("command", _tour(), ids=lambda c: f"line{c.line}-{c.args[0]}")
def test_every_readme_example_prints_what_it_shows(command: Command, tmp_path):
    result = run_vsw(command.args, tmp_path)
    where = f"README.md:{command.line}: vsw {' '.join(command.args)}"
    assert result.returncode == 0, f"{where} exited {result.returncode}: {result.stderr}"
    printed = result.stdout.rstrip("\n").split("\n")
    assert shown_in_order(command.shown, printed), (
        f"{where}: a shown line is not printed (or not in this order).\n--- shown\n"
        + "\n".join(command.shown)
        + "\n--- printed\n"
        + "\n".join(printed)
    )
