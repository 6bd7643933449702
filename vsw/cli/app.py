"""The ``vsw`` program: its parser (one module per command) and the entry point.

Standard output failures are handled once, in :func:`main`, for every command: while a
command runs, ``sys.stdout`` is a thin wrapper that remembers the first write error, and
:func:`main` flushes it before returning, so a closed pipe or a full disk is seen here and
not in the interpreter's final flush; afterwards the file descriptor is pointed at
``os.devnull`` so that flush at exit stays quiet (the recipe of Python's ``signal``
documentation, "Note on SIGPIPE").
"""

from __future__ import annotations

import argparse
import atexit
import importlib
import math
import os
import shutil
import stat
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn, TextIO

from vsw.cli.output import version
from vsw.cli.parser import (
    EXIT_CLOSED_PIPE,
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_SOLVER,
    ArgumentParser,
    TopHelpFormatter,
    UsageError,
    epilog,
)
from vsw.runtime import blas, stop
from vsw.runtime.errors import ConvergenceError, InfeasibleError, SlowRouteWarning, VswInputError
from vsw.runtime.limits import max_memory, max_seconds
from vsw.runtime.threads import default_threads

__all__ = ["COMMANDS", "build_parser", "main"]

COMMANDS = {
    "models": "vsw.cli.models",
    "analyze": "vsw.cli.analyze",
    "simulate": "vsw.cli.simulate",
    "animate": "vsw.cli.animate",
    "explore": "vsw.cli.explore",
    "basin": "vsw.cli.basin",
    "sweep": "vsw.cli.sweep",
    "continue": "vsw.cli.continuation",
    "design": "vsw.cli.design",
    "optimize": "vsw.cli.optimize",
    "rough": "vsw.cli.rough",
    "hzd": "vsw.cli.hzd",
}
"""The commands, in the order ``vsw --help`` lists them, and the module of each: it has
``register`` (adds the command's parser) and ``run``. A command's module is imported when
its parser is built (:func:`build_parser`): one run imports only its own command's
module and what that needs (``vsw basin`` no optimizer, design or continuation code)."""


class _VersionAction(argparse.Action):
    """``--version``: looks the version up only when asked (importlib.metadata is slow)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, **kw):
        kw.setdefault("help", "show the version and exit")
        super().__init__(option_strings, dest=dest, default=argparse.SUPPRESS, nargs=0, **kw)

    def __call__(self, parser, namespace, values, option_string=None) -> NoReturn:
        sys.stdout.write(f"vsw {version()}\n")
        parser.exit()


def build_parser(command: str | None = None) -> ArgumentParser:
    """The ``vsw`` parser: with every command, or with ``command`` alone (a name of
    :data:`COMMANDS`; anything else builds every command's).

    A command line whose first argument is a command parses the same either way: the
    top-level parser has only options that take no value, so it hands that argument and
    everything after it to the command's parser, and never looks at the others. Every
    other command line (``vsw --help``, no command, an unknown one, ``vsw --version``)
    gets the whole parser, so its help and its errors list every command."""
    parser = ArgumentParser(
        prog="vsw",
        description="Walking models derived and verified: the instantaneous leg extension "
        "model of Virtual Slope Walking (the default model) and the others of 'vsw models'.\n"
        "Every command takes --model NAME and the model's parameters (defaults apply).",
        epilog=epilog(),
        formatter_class=TopHelpFormatter,
    )
    parser.add_argument("--version", action=_VersionAction)
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in [command] if command in COMMANDS else COMMANDS:
        importlib.import_module(COMMANDS[name]).register(subparsers)
    return parser


class _GuardedStdout:
    """``sys.stdout`` while a command runs: remembers the first OSError of a write.

    Some writers swallow errors (argparse's help does); remembering the first one lets
    :func:`main` tell a failing standard output from any other OSError (a plot file) and
    handle it in one place for every subcommand.
    """

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.error: OSError | None = None

    def _call(self, method: str, *args: Any) -> Any:
        try:
            return getattr(self.stream, method)(*args)
        except OSError as exc:
            if self.error is None:
                self.error = exc
            raise

    def write(self, text: str) -> int:
        stop.check()  # nothing of a stopped run reaches standard output
        return self._call("write", text)

    def writelines(self, lines: Any) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        self._call("flush")

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


def _one_line(text: Any) -> str:
    return " ".join(str(text).split())


def _check_environment() -> None:
    """Every ``VSW_*`` setting read as the commands will, before any of them starts.

    One rule for every subcommand and input size: an invalid setting is bad input even
    where the command would not have needed it.
    """
    default_threads()
    max_seconds()
    max_memory()


def _limit_or_none() -> float:
    """The run-time limit to run under, or none while an invalid ``VSW_MAX_SECONDS`` waits
    for :func:`_check_environment` to refuse it after the command line is parsed (a usage
    error is said first, as for every other setting)."""
    try:
        return max_seconds()
    except VswInputError:
        return math.inf


def _writable(directory: Path) -> bool:
    """Whether ``directory`` is, or could be made (``mkdir -p``), a writable directory;
    nothing is created."""
    for path in (directory, *directory.parents):
        if path.exists():
            return path.is_dir() and os.access(path, os.W_OK | os.X_OK)
    return False


def _matplotlib_config() -> None:
    """Point ``MPLCONFIGDIR`` at a writable directory when Matplotlib's own would not be.

    Matplotlib otherwise warns in two lines on every plotting run with a read-only (or
    missing) home directory, and rebuilds its font cache each time. Decided before any
    command imports Matplotlib, without importing it and without creating anything in the
    home directory: its XDG config and cache directories are checked; where either is not
    writable, ``<tmp>/vsw-matplotlib-<uid>`` (kept, so its font cache is reused) serves,
    or a fresh temporary directory when that one is not safely ours."""
    if os.environ.get("MPLCONFIGDIR") or not sys.platform.startswith(("linux", "freebsd")):
        return
    home = Path(os.environ.get("HOME") or "/")
    config = Path(os.environ.get("XDG_CONFIG_HOME") or home / ".config") / "matplotlib"
    cache = Path(os.environ.get("XDG_CACHE_HOME") or home / ".cache") / "matplotlib"
    if _writable(config) and _writable(cache):
        return
    import tempfile

    kept = Path(tempfile.gettempdir()) / f"vsw-matplotlib-{os.getuid()}"
    try:
        kept.mkdir(mode=0o700, exist_ok=True)
        info = kept.lstat()
        # A directory someone else made or may write in is not used (a shared /tmp).
        ours = stat.S_ISDIR(info.st_mode) and info.st_uid == os.getuid()
        if not (ours and info.st_mode & 0o077 == 0):
            kept = Path(tempfile.mkdtemp(prefix="vsw-matplotlib-"))
            atexit.register(shutil.rmtree, kept, ignore_errors=True)
    except OSError:
        return  # no writable temporary directory either: Matplotlib's own warning applies
    os.environ["MPLCONFIGDIR"] = str(kept)


def _say(line: str) -> None:
    """One line on stderr; silent when stderr itself is closed or broken."""
    try:
        sys.stderr.write(line + "\n")
        sys.stderr.flush()
    except (AttributeError, OSError):
        pass


def _silence(stream: TextIO) -> None:
    """Point the file descriptor of a failed ``stream`` at os.devnull.

    What is still buffered then goes nowhere at the interpreter's final flush instead of
    failing again there with "Exception ignored ...". Streams without a descriptor (a
    test's capture) are not flushed at exit, so there is nothing to do.
    """
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError):
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, fd)
    finally:
        os.close(devnull)


def _warning_printer(stream: TextIO) -> Callable[..., None]:
    """``warnings.showwarning`` for a command: a SlowRouteWarning as one line on
    ``stream`` (the command's stderr, which solver work may have redirected since), any
    other warning as Python shows it."""
    shown = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        if not issubclass(category, SlowRouteWarning):
            shown(message, category, filename, lineno, file, line)
            return
        try:
            stream.write(f"vsw: warning: {message}\n")
            stream.flush()
        except (AttributeError, OSError):
            pass

    return show


def _drop_pending_output(program: bool) -> None:
    """In the ``vsw`` program (not a caller's process, whose standard output must stay),
    a stopped run's output still in standard output's buffer (a result finished just
    before the stop) goes nowhere: the descriptor is pointed at os.devnull. What was
    flushed before stays out."""
    if program:
        _silence(sys.stdout)


def _run(argv: Sequence[str] | None, program: bool) -> int:
    """Parse and run one command; every error but a failing standard output is mapped here."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        parser = build_parser(argv[0] if argv else None)
        with stop.supervised(_limit_or_none()), warnings.catch_warnings():
            # Parsing is supervised too: it loads the model, which for a model file of the
            # user's derives it first in a subprocess (vsw.models.user), killed with the
            # stop when the limit passes or Ctrl-C comes.
            args = parser.parse_args(argv)
            args.argv = argv
            _check_environment()
            _matplotlib_config()
            warnings.simplefilter("once", SlowRouteWarning)
            warnings.showwarning = _warning_printer(sys.stderr)
            # VSW_THREADS bounds the whole command: its walks' threads and BLAS's.
            with blas.limited(default_threads()):
                code = int(args.func(args))
            stop.check()  # a stop a library turned into a result is still a stop
            stop.settle()
        return code
    except VswInputError as exc:
        stop.settle()
        if isinstance(exc, stop.RunTimeLimitError):
            _drop_pending_output(program)
        prog = exc.prog if isinstance(exc, UsageError) else "vsw"
        _say(f"{prog}: error: {_one_line(exc)}")
        return EXIT_INPUT
    except (ConvergenceError, InfeasibleError) as exc:
        stop.settle()
        _say(f"vsw: {type(exc).__name__}: {_one_line(exc)}")
        return EXIT_SOLVER
    except SystemExit as exc:  # --help and --version exit through argparse
        stop.settle()
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    except MemoryError:
        stop.settle()
        _say(
            "vsw: error: out of memory; use a smaller problem, or lower VSW_MAX_MEMORY so "
            "that such work is refused before it starts"
        )
        return EXIT_INPUT
    except KeyboardInterrupt:
        stop.settle()
        _drop_pending_output(program)
        _say("vsw: interrupted")
        return EXIT_INTERRUPTED


def main(argv: Sequence[str] | None = None, *, program: bool = False) -> int:
    """Run the CLI; returns the exit status (the console script exits with it).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.
    program : bool
        True in the ``vsw`` program itself (vsw/__main__.py): a stopped run's output still
        buffered is then dropped (its standard output is the process's to end).

    Returns
    -------
    int
        One of :data:`EXIT_STATUS`: 0 success, 2 bad input (one line on stderr), 3 solver
        failure or infeasible request, 141 standard output closed by its reader (quiet),
        130 interrupted.
    """
    stdout = sys.stdout
    if stdout is None:  # started with standard output closed (">&-")
        _say("vsw: error: standard output is closed; redirect it (e.g. >/dev/null) instead")
        return EXIT_INPUT
    guard = _GuardedStdout(stdout)
    sys.stdout = guard
    try:
        code = _run(argv, program)
        # Flushed here, not at exit, so that a closed pipe or a full disk is seen here.
        guard.flush()
    except OSError as exc:
        if guard.error is None:  # a file the command writes (a plot), not standard output
            where = f" {exc.filename!r}" if exc.filename else ""
            _say(f"vsw: error: cannot write{where}: {exc.strerror or _one_line(exc)}")
            code = EXIT_INPUT
    finally:
        sys.stdout = stdout
    if guard.error is not None:
        _silence(stdout)
        if isinstance(guard.error, BrokenPipeError):
            return EXIT_CLOSED_PIPE  # the reader has all it wanted: no message
        _say(f"vsw: error: cannot write standard output: {guard.error.strerror or guard.error}")
        return EXIT_INPUT
    return code
