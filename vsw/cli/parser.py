"""The argument parser every ``vsw`` command is built with, and the exit statuses.

:class:`ArgumentParser` reports usage errors as one line (:class:`UsageError`, exit 2),
shows each option's default once in ``--help`` and marks the required ones; a command's
checks that need several options at once (the model and its parameters) run where
argparse makes its own (``after_parse``), so their errors come in the same order.
"""

from __future__ import annotations

import argparse
import textwrap
from collections.abc import Sequence
from typing import Any, NoReturn

from vsw.runtime.errors import VswInputError

__all__ = [
    "EXIT_CLOSED_PIPE",
    "EXIT_INPUT",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_SOLVER",
    "EXIT_STATUS",
    "ArgumentParser",
    "StoreGiven",
    "UsageError",
    "epilog",
    "given",
]

EXIT_OK = 0
EXIT_INPUT = 2
EXIT_SOLVER = 3
EXIT_INTERRUPTED = 130
EXIT_CLOSED_PIPE = 141  # 128 + SIGPIPE (13): what a shell reports for a broken pipe

EXIT_STATUS = {
    EXIT_OK: "success",
    EXIT_INPUT: "bad input (one line on stderr): arguments, VSW_* settings, work beyond "
    "the time or memory limit (estimated before it starts, or stopped when it runs past "
    "VSW_MAX_SECONDS), a plot file or standard output that cannot be written",
    EXIT_SOLVER: "a solver did not converge, or a design request is infeasible",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C)",
    EXIT_CLOSED_PIPE: "standard output closed by its reader (e.g. '| head'): quiet, "
    "as a program ended by SIGPIPE",
}
"""Every exit status of ``vsw`` and its meaning."""

ENVIRONMENT = (
    (
        "VSW_THREADS",
        "worker threads for large evaluations, 1-256, and at most as many for numpy's and "
        "SciPy's BLAS: at most this many busy cores (default: the usable cores)",
    ),
    (
        "VSW_MAX_SECONDS",
        "refuse work estimated to take longer, and stop a run at it, in s (default 3600; "
        "inf: none)",
    ),
    (
        "VSW_MAX_MEMORY",
        "refuse work estimated to need more memory, e.g. 8G (default: 80% of the "
        "available memory; inf: none)",
    ),
    (
        "VSW_KERNELS",
        "0: use the generated numpy code and SciPy instead of the compiled C kernels and "
        "simulators",
    ),
    (
        "VSW_CACHE_DIR",
        "what vsw builds and keeps: compiled kernels and simulators, models derived from "
        "your model files, kept gait searches (default ~/.cache/vsw)",
    ),
    (
        "VSW_MODELS_DIR",
        "where models derived from your model files are kept (default VSW_CACHE_DIR/models)",
    ),
    (
        "VSW_SEARCH_CACHE",
        "0: search for gaits anew each time instead of reading a kept search "
        "(kept in VSW_CACHE_DIR/searches)",
    ),
    ("VSW_DASK_SCHEDULER", "run basins on this Dask scheduler (as --scheduler)"),
)


class UsageError(VswInputError):
    """An argparse usage error; ``prog`` is the (sub)command it belongs to."""

    def __init__(self, prog: str, message: str) -> None:
        super().__init__(message)
        self.prog = prog


class HelpFormatter(argparse.HelpFormatter):
    """Adds ``(default: X)`` to an option's help where there is a default to show, once,
    and ``(required)`` to a required option's."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if action.required and action.option_strings:
            return f"{text} (required)".strip()
        if (
            action.default is None
            or action.default is argparse.SUPPRESS
            or isinstance(action.default, bool)
            or not action.option_strings
            or "(default" in text
        ):
            return action.help
        return f"{text} (default: %(default)s)".strip()


class TopHelpFormatter(argparse.RawDescriptionHelpFormatter, HelpFormatter):
    """The ``vsw`` parser's formatter: its epilog (exit statuses, environment) is a table."""


class ArgumentParser(argparse.ArgumentParser):
    """argparse that reports usage errors as one-line :class:`UsageError` (exit 2).

    Every parser made from it, including the subcommand parsers (argparse makes them of the
    parent's class), uses :class:`HelpFormatter` unless given another formatter, and takes
    an option only by its whole name: argparse's prefix matching would take ``--bet`` as
    ``--beta`` silently, and a prefix that is unique today becomes ambiguous, or another
    option, when an option is added.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        raise UsageError(self.prog, f"{message} (see '{self.prog} --help')")

    def parse_known_args(self, args: Any = None, namespace: Any = None) -> Any:
        # A command may set ``after_parse(parser, namespace)``: checks that need several
        # options (the model and its parameters), made where argparse makes its own, so
        # that their errors come in the same order (before an unrecognized argument).
        namespace, extras = super().parse_known_args(args, namespace)
        check = getattr(self, "after_parse", None)
        if check is not None:
            check(self, namespace)
        return namespace, extras

    def _get_values(self, action: argparse.Action, arg_strings: list[str]) -> Any:
        # Python 3.11's argparse drops a "--" value, so "--beta=--" gives beta = [] (not
        # a float, past the type check): refuse it as the missing value it has become.
        value = super()._get_values(action, arg_strings)
        if action.nargs is None and action.option_strings and value == []:
            self.error(f"argument {'/'.join(action.option_strings)}: expected one argument")
        return value


class StoreGiven(argparse.Action):
    """``store`` that also records that the option was given (its default may be a value)."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        setattr(namespace, self.dest, values)
        namespace.given = set(getattr(namespace, "given", ())) | {self.dest}


def given(parser: argparse.ArgumentParser, args: argparse.Namespace, dest: str) -> bool:
    """Whether the option ``dest`` was on the command line (a :class:`StoreGiven` one by
    its record, any other by a value other than its default None/False)."""
    action = next(a for a in parser._actions if a.dest == dest)
    if isinstance(action, StoreGiven):
        return dest in getattr(args, "given", ())
    return getattr(args, dest, None) not in (None, False)


def option_name(parser: argparse.ArgumentParser, dest: str) -> str:
    """The option strings of ``dest`` (``--theta-min``)."""
    action = next(a for a in parser._actions if a.dest == dest)
    return "/".join(action.option_strings)


def epilog() -> str:
    """The top-level help's epilog: exit statuses and the environment."""

    def table(rows: Sequence[tuple[Any, str]]) -> list[str]:
        width = max(len(str(key)) for key, _ in rows)
        wrap = textwrap.TextWrapper(79, subsequent_indent=" " * (width + 4))
        return [wrap.fill(f"  {key!s:<{width}}  {text}") for key, text in rows]

    lines = ["exit status:", *table(list(EXIT_STATUS.items())), "", "environment:"]
    lines += [*table(ENVIRONMENT), ""]
    lines.append(textwrap.fill(
        "Parameters in the units of 'vsw models' (angles in rad, or with a deg suffix: "
        "--param phi0=45deg), in every NAME=VALUE option (--fix, --bound, --over, --state); "
        "the named --theta-ii and --phi0 (and design's --theta-ii-min/max, --phi0-min/max) "
        "in degrees; JSON in the model's units (angles in rad).", 79,
    ))  # fmt: skip
    return "\n".join(lines)
