"""The thin CLI: one module per command under ``navbench.cli.commands``.

When this package is imported by the ``navbench`` command itself (the console script, or
``python -m navbench.cli.main``), Ctrl-C during the imports that precede :func:`main` (typer,
the command modules, the bundled profiles read for the help texts: up to a second on a loaded
machine) ends the process with the same one line and exit 130 as Ctrl-C later on, instead of a
KeyboardInterrupt traceback from inside an import (issue 34, probe P-006). :func:`main` puts
Python's own handler back first thing. A program that imports navbench as a library keeps its
own Ctrl-C handling.
"""

import os as _os
import signal as _signal
import sys as _sys


def _interrupted_during_import(signum, frame):  # pragma: no cover - timing-dependent
    try:
        _os.write(2, b"interrupted\n")
    finally:
        _os._exit(130)  # nothing is written yet: no file, no row, no cache entry


def _is_the_navbench_command() -> bool:
    argv0 = _os.path.basename(_sys.argv[0]) if _sys.argv and _sys.argv[0] else ""
    return argv0 == "navbench" or "navbench.cli.main" in getattr(_sys, "orig_argv", [])[1:3]


if _is_the_navbench_command() and _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler:
    _signal.signal(_signal.SIGINT, _interrupted_during_import)
