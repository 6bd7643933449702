"""``python -m vsw`` and the ``vsw`` console script: the vsw command line.

Importing the command line (numpy, CasADi, the generated models) takes about half a
second; a Ctrl-C in that time must end the program as one during a command does (one
line, exit 130), not with an import traceback, so the handler is installed before the
import. A Ctrl-C after the command's result is out is ignored (the whole result, exit 0),
where Python's own handler would kill the exiting process by the signal.
"""

import os
import signal
import sys

_started_interrupted = False


def _interrupted_while_starting(signum, frame) -> None:
    global _started_interrupted
    _started_interrupted = True
    sys.stderr.write("vsw: interrupted\n")
    sys.stderr.flush()
    # Out at once: nothing is done yet, and an exception raised into an import can be
    # swallowed by the library being imported, or leave it half made for the interpreter's
    # finalisation to wait on (a start-up Ctrl-C once left the process running on).
    os._exit(130)


def run() -> int:
    """The console script's entry point (``vsw.cli.main`` behind a start-up Ctrl-C)."""
    signal.signal(signal.SIGINT, _interrupted_while_starting)
    try:
        from vsw.runtime.threads import size_blas_pools

        size_blas_pools()  # before numpy loads its BLAS (vsw.runtime.threads)
        from vsw.cli import main
        from vsw.runtime import stop  # after the handler on purpose (module docstring)
    except BaseException:
        # A Ctrl-C inside an extension's initialisation (numpy's) reaches us as that
        # library's ImportError wrapping the handler's exit: still the interrupt.
        if _started_interrupted:
            raise SystemExit(130) from None
        raise

    # Kept to the end: a command's run installs its own handler and gives this one back,
    # which then ignores a Ctrl-C that comes after the outcome is settled (stop.settle).
    signal.signal(signal.SIGINT, stop.interrupt_unless_settled)
    code = main(program=True)
    # Ignored by the system itself from here on: Python's finalisation gives a handled
    # signal its default action back (death by SIGINT), but leaves an ignored one alone.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    return code


if __name__ == "__main__":
    raise SystemExit(run())
