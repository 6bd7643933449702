"""``python -m vsw`` and the ``vsw`` console script: the vsw command line.

Importing the command line (numpy, CasADi, the generated models) takes about half a
second; a Ctrl-C in that time must end the program as one during a command does (one
line, exit 130), not with an import traceback, so the handler is installed before the
import.
"""

import signal
import sys


def _interrupted_while_starting(signum, frame) -> None:
    sys.stderr.write("vsw: interrupted\n")
    raise SystemExit(130)


def run() -> int:
    """The console script's entry point (``vsw.cli.main`` behind a start-up Ctrl-C)."""
    previous = signal.signal(signal.SIGINT, _interrupted_while_starting)
    from vsw.cli import main  # after the handler on purpose (module docstring)

    signal.signal(signal.SIGINT, previous)
    return main()


if __name__ == "__main__":
    raise SystemExit(run())
