"""The ``vsw`` command line (also ``python -m vsw``): one module per command.

Every command runs any model through the one model interface (:mod:`vsw.models`): ``models``,
``analyze``, ``simulate``, ``animate``, ``explore``, ``basin``, ``sweep``, ``design``. The
shared pieces: :mod:`vsw.cli.parser` (one-line usage errors, exit statuses),
:mod:`vsw.cli.options` (the model and its parameters), :mod:`vsw.cli.output` (the JSON
envelope every command's output starts with, and the text tables' parts), and
:mod:`vsw.cli.app` (the entry point).

Exit status: 0 success; 2 bad input (one line on stderr, never a traceback); 3 a solver
did not converge or a design request is infeasible; 130 interrupted; 141 standard output
closed by its reader (quiet, as a program ended by SIGPIPE).
"""

from vsw.cli.app import COMMANDS, build_parser, main
from vsw.cli.parser import (
    EXIT_CLOSED_PIPE,
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_SOLVER,
    EXIT_STATUS,
    ArgumentParser,
    UsageError,
)

__all__ = [
    "COMMANDS",
    "EXIT_CLOSED_PIPE",
    "EXIT_INPUT",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_SOLVER",
    "EXIT_STATUS",
    "ArgumentParser",
    "UsageError",
    "build_parser",
    "main",
]
