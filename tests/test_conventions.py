"""One convention in every command: whole option names, the environment the help lists,
one name for a start state, one meaning of a plain number, one unit per quantity, and a
unit for every number of the JSON output."""

from __future__ import annotations

import argparse

import pytest

from vsw.cli import main
from vsw.cli.app import COMMANDS, build_parser


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_every_parser_refuses_abbreviations():
    parser = build_parser()
    assert parser.allow_abbrev is False
    for name, sub in _subparsers(parser).items():
        assert sub.allow_abbrev is False, name


@pytest.mark.parametrize(
    "argv",
    [
        ["analyze", "--bet", "0.8"],
        ["simulate", "--stat", "x=1"],
        ["design", "--maximize", "speed", "--fi", "beta=0.8"],
        ["basin", "--mod", "ile"],
    ],
)
def test_an_abbreviated_option_is_a_one_line_usage_error(capsys, argv):
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert len(err.strip().splitlines()) == 1
    assert "unrecognized arguments" in err and argv[-2] in err


def test_every_command_is_checked():
    assert set(_subparsers(build_parser())) == set(COMMANDS)
