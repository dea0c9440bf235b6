"""The ``navbench`` typer app.

Each module in :mod:`navbench.cli.commands` defines ``register(app)`` and adds its command(s);
they are discovered here so that commands never edit this file. Command modules import only
light modules at import time (typer, rich, the standard library): torch, numba and pymunk are
imported inside the command functions, so ``navbench --help`` answers at once.

Errors derived from :class:`navbench.errors.NavbenchError` are printed as one line on stderr
with exit code 2; anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import errno
import importlib
import inspect
import pkgutil
import sys
from pathlib import Path

import typer

from navbench import __version__
from navbench.cli import _interrupted_during_import

app = typer.Typer(
    name="navbench",
    help="Reproduce 'Tracking and Planning with Spatial World Models': levels, simulator, "
    "world models, navigation and tracking experiments with a results database.",
    no_args_is_help=True,
    add_completion=True,  # --install-completion / --show-completion SHELL
    pretty_exceptions_enable=False,
    rich_markup_mode="rich",
)


def _version(value: bool):
    if value:
        typer.echo(f"navbench {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                 help="Print the version and exit."),
):
    """navbench: experiment orchestration for spatial world models."""


def _register_all() -> None:
    from navbench.cli import commands

    for mod in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if mod.name.startswith("_"):
            continue
        module = importlib.import_module(f"{commands.__name__}.{mod.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(app)


def _reflow(doc: str) -> str:
    """``doc`` with each paragraph on one line. In rich markup mode typer keeps a docstring's
    single line breaks, so text wrapped for the source came out ragged at any terminal width;
    paragraphs (blank-line separated) and ``\\b`` blocks are kept."""
    paragraphs = inspect.cleandoc(doc).split("\n\n")
    return "\n\n".join(p if p.startswith("\b") else " ".join(p.split()) for p in paragraphs)


def _reflow_help(typer_app: typer.Typer) -> None:
    """Reflow the help of every command of ``typer_app`` and of its sub-apps (``db``, ``cache``)."""
    for info in typer_app.registered_commands:
        doc = info.help or (info.callback.__doc__ if info.callback else None)
        if doc:
            info.help = _reflow(doc)
    for group in typer_app.registered_groups:
        if group.typer_instance is not None:
            _reflow_help(group.typer_instance)


class _FiniteFloat:
    """Parser of a ``float`` option: a finite number within the option's ``min``/``max``.

    typer (and click) accept ``nan``, ``inf`` and ``1e400`` for a float option, and a NaN slips
    through any range check (every comparison with it is false); every float option of every
    command is given this parser by :func:`_finite_numbers`, so none can reach a command."""

    def __init__(self, lo, hi, label: str):
        self.lo, self.hi, self.label = lo, hi, label

    def __call__(self, value):
        import math

        if isinstance(value, (int, float)) and not isinstance(value, bool):
            x = float(value)
        else:
            try:
                x = float(str(value).strip())
            except ValueError:
                raise typer.BadParameter(f"{value!r} is not a number") from None
        if not math.isfinite(x):  # one line naming the option, as the commands' own checks
            from navbench.errors import ConfigError

            raise ConfigError(f"{self.label}: expected a finite number, got {value!r}")
        if self.lo is not None and x < self.lo:
            raise typer.BadParameter(f"{value!r} is below the minimum {self.lo:g}")
        if self.hi is not None and x > self.hi:
            raise typer.BadParameter(f"{value!r} is above the maximum {self.hi:g}")
        return x


#: Largest integer any option takes (numpy's int64; seeds, counts and sizes are far below it).
MAX_INT_OPTION = 2**63 - 1


def _finite_numbers(typer_app: typer.Typer) -> None:
    """Every ``float`` option or argument of every command (and of the sub-apps) refuses NaN,
    infinities and overflowing literals (:class:`_FiniteFloat`), and every ``int`` one
    integers beyond int64, as usage errors (exit 2) before the command runs (issue 34)."""
    from typer.models import ArgumentInfo, OptionInfo

    for info in typer_app.registered_commands:
        if info.callback is None:
            continue
        for prm in inspect.signature(info.callback).parameters.values():
            d = prm.default
            if not isinstance(d, (OptionInfo, ArgumentInfo)) or d.parser is not None:
                continue
            ann = prm.annotation if isinstance(prm.annotation, str) else getattr(prm.annotation, "__name__", "")
            ann = ann.replace(" ", "")
            if ann in ("float", "float|None", "Optional[float]"):
                decls = [x for x in (d.param_decls or ()) if x.startswith("--")]
                label = decls[0] if decls else (f"--{prm.name.replace('_', '-')}"
                                                 if isinstance(d, OptionInfo) else prm.name.upper())
                d.parser = _FiniteFloat(d.min, d.max, label)
                d.min = d.max = None  # checked by the parser (typer ignores them with one)
            elif ann in ("int", "int|None", "Optional[int]") and d.max is None and not d.count:
                d.max = MAX_INT_OPTION
    for group in typer_app.registered_groups:
        if group.typer_instance is not None:
            _finite_numbers(group.typer_instance)


_register_all()
_reflow_help(app)
_finite_numbers(app)


def _click_kind(e: BaseException) -> str | None:
    """``"Exit"``, ``"Abort"`` or ``"ClickException"`` when *e* is one of click's control-flow
    exceptions (or typer's own Exit/Abort), else None. Matched by class name along the MRO so
    that it works with click itself (typer < 0.29) and with typer's vendored copy
    (``typer._click``, typer >= 0.29) without importing either."""
    for cls in type(e).__mro__:
        ours = "click" in cls.__module__ or cls.__module__ == "typer.exceptions"
        if ours and cls.__name__ in ("Exit", "Abort", "ClickException"):
            return cls.__name__
    return None


#: OSError numbers that the environment causes, not a bug: a full disk or quota, a read-only
#: or forbidden folder, a path component that is a file (``results/cache`` replaced by one).
_ENV_ERRNOS = {errno.ENOSPC, getattr(errno, "EDQUOT", -1), errno.EROFS, errno.EACCES, errno.EPERM,
               errno.ENOTDIR, errno.EISDIR, errno.EEXIST, errno.EMFILE, errno.ENFILE, errno.ENAMETOOLONG,
               errno.ELOOP}


def _chain(e: BaseException):
    """``e`` and every exception it was raised from or during (``__cause__``/``__context__``)."""
    seen = set()
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        yield e
        e = e.__cause__ or e.__context__


def _interrupted(e: BaseException) -> bool:
    """Whether ``e`` is, or was caused by, Ctrl-C (:func:`navbench.errors.caused_by_interrupt`)."""
    from navbench.errors import caused_by_interrupt

    return caused_by_interrupt(e)


def _env_oserror(e: BaseException) -> OSError | None:
    """The environment's OSError (disk full, read-only, not a directory, a symbolic-link loop,
    ...) behind ``e``. ``Path.resolve()`` reports a link loop as a RuntimeError ("Symlink loop
    from '...'"), turned here into the ELOOP it is."""
    import re

    for x in _chain(e):
        if isinstance(x, OSError) and x.errno in _ENV_ERRNOS:
            return x
        m = re.fullmatch(r"Symlink loop from (['\"])(.*)\1", str(x)) if type(x) is RuntimeError else None
        if m:
            return OSError(errno.ELOOP, "a symbolic-link loop", m.group(2))
    return None


def _env_problem(env: dict) -> str | None:
    """One line naming an environment variable navbench cannot run with, else None.

    Checked before any heavy import, since numba and torch read them at import time and fail
    there with a traceback (``NUMBA_NUM_THREADS=abc``) or quietly do the wrong thing (an
    unusable ``NUMBA_CACHE_DIR`` makes numba write its cache beside the package)."""
    import re

    for var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        v = env.get(var)
        if v is None:
            continue
        parts = v.strip().split(",") if var == "OMP_NUM_THREADS" else [v.strip()]
        if not all(re.fullmatch(r"[0-9]{1,4}", x) and 1 <= int(x) <= 4096 for x in parts):
            return (f"{var}={v!r}: expected a whole number of threads in [1, 4096] "
                    f"(or unset it)")
    cache = env.get("NUMBA_CACHE_DIR")
    if cache is not None:
        import os

        c = Path(cache)
        probe = c if c.exists() else next((q for q in c.parents if q.exists()), None)
        if (not cache.strip() or probe is None or not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK)
                or not _writable_folder(c)):
            return (f"NUMBA_CACHE_DIR={cache!r}: not a writable folder (numba would write its "
                    f"cache beside the package); point it at a writable folder or unset it")
    return None


def _writable_folder(c: Path) -> bool:
    """Whether folder ``c`` exists or can be made, and a file can be written in it: tried, not
    judged by permission bits, which say yes to root on /proc or a read-only file system."""
    import os
    import tempfile

    try:
        c.mkdir(parents=True, exist_ok=True)  # numba would make it too
        fd, name = tempfile.mkstemp(prefix=".navbench-probe-", dir=c)
        os.close(fd)
        os.unlink(name)
    except OSError:
        return False
    return True


_MPL_BACKENDS = {"agg", "pdf", "ps", "svg", "pgf", "cairo", "template", "tkagg", "tkcairo",
                 "qtagg", "qtcairo", "qt5agg", "qt5cairo", "gtk3agg", "gtk3cairo", "gtk4agg",
                 "gtk4cairo", "wxagg", "wxcairo", "macosx", "webagg", "nbagg", "ipympl", "widget",
                 "inline"}


def _sanitise_env(env: dict) -> None:
    """Fix what navbench can fix without changing results: an unknown ``MPLBACKEND`` (navbench
    only draws into files) becomes ``Agg``; standard streams whose ``PYTHONIOENCODING`` cannot
    encode a message replace the character instead of raising ``UnicodeEncodeError``."""
    b = env.get("MPLBACKEND")
    if b is not None and b.strip().lower() not in _MPL_BACKENDS and not b.startswith("module://"):
        env["MPLBACKEND"] = "Agg"
    import codecs

    for stream in (sys.stdout, sys.stderr):
        enc, errs = getattr(stream, "encoding", None), getattr(stream, "errors", None)
        reconf = getattr(stream, "reconfigure", None)
        if reconf is None or enc is None:
            continue
        try:
            codecs.lookup(enc)
            codecs.lookup_error(errs or "strict")
            if (errs or "strict") == "strict":
                reconf(errors="replace")
        except LookupError:
            reconf(encoding="utf-8", errors="replace")
        except (ValueError, OSError):  # a closed or detached stream: leave it
            pass


def _fail(msg: str, code: int = 2) -> None:
    typer.secho(f"error: {msg}", err=True, fg=typer.colors.RED)
    sys.exit(code)


#: A Ctrl-C that Python swallowed (see :func:`_unraisable_hook`), honoured when the command ends.
_SWALLOWED_INTERRUPT: list[bool] = []


def _unraisable_hook(unraisable) -> None:
    """``sys.unraisablehook`` of the CLI. A Ctrl-C that lands inside a finaliser or a weakref
    callback (matplotlib makes many) is "unraisable": Python prints "Exception ignored ...
    KeyboardInterrupt" with a traceback and carries on as if nothing happened (the blind probe's
    ``report``: a traceback, then exit 0). It cannot be raised again from here (the hook's own
    exceptions are ignored too), so it is remembered, nothing is printed, and :func:`main` ends
    the command as interrupted (one line, exit 130) when it returns. Anything else goes to
    Python's own hook."""
    if isinstance(unraisable.exc_type, type) and issubclass(unraisable.exc_type, KeyboardInterrupt):
        _SWALLOWED_INTERRUPT.append(True)
        return
    sys.__unraisablehook__(unraisable)


def main(argv: list[str] | None = None) -> None:
    """Console entry point: run the app, turning NavbenchError into a one-line message and
    usage errors into click's short usage message (exit 2).

    Also one line, never a traceback, for what a user's environment causes (issue 34): a
    variable numba or torch cannot run with (exit 2, before anything runs), Ctrl-C at any
    moment (exit 130, even when it arrived inside a compiled kernel), and a full disk,
    read-only folder or a file where a folder belongs (exit 2, naming the path)."""
    import os
    import signal

    from navbench.errors import NavbenchError

    if signal.getsignal(signal.SIGINT) is _interrupted_during_import:  # the imports are done
        signal.signal(signal.SIGINT, signal.default_int_handler)
    _sanitise_env(os.environ)
    sys.unraisablehook = _unraisable_hook
    problem = _env_problem(os.environ)
    if problem is not None:
        _fail(problem)
    try:
        rv = app(args=argv, standalone_mode=False)
    except NavbenchError as e:
        # typer.secho prints the text as is (no rich markup: user text may hold "[/x]")
        _fail(str(e).replace("\n", " "))
    except KeyboardInterrupt:
        typer.secho("interrupted", err=True, fg=typer.colors.YELLOW)
        sys.exit(130)
    except Exception as e:
        kind = _click_kind(e)
        if kind == "Exit":
            sys.exit(e.exit_code)
        if kind == "Abort":
            if _interrupted(e):  # click turns Ctrl-C into Abort (raised from the KeyboardInterrupt)
                typer.secho("interrupted", err=True, fg=typer.colors.YELLOW)
                sys.exit(130)
            typer.secho("aborted", err=True)
            sys.exit(1)
        if kind == "ClickException":  # usage errors (bad option, value out of range, missing argument)
            e.show()
            sys.exit(e.exit_code)
        if _interrupted(e):
            typer.secho("interrupted", err=True, fg=typer.colors.YELLOW)
            sys.exit(130)
        ose = _env_oserror(e)
        if ose is not None:
            where = ose.filename if ose.filename is not None else "navbench"
            fix = ("replace the link" if ose.errno == errno.ELOOP
                   else "free space or fix the folder's permissions")
            _fail(f"{where}: {ose.strerror or os.strerror(ose.errno)} (nothing was stored for the "
                  f"step that failed; {fix} and rerun)")
        raise
    # with standalone_mode=False, click returns typer.Exit(n)'s code; typer >= 0.29 turns a
    # KeyboardInterrupt into Exit(130) and returns 130 without a word (commands that report
    # Ctrl-C themselves exit through SystemExit and do not come back here)
    if rv == 130 or _SWALLOWED_INTERRUPT:  # a Ctrl-C Python swallowed counts as one
        typer.secho("interrupted", err=True, fg=typer.colors.YELLOW)
        sys.exit(130)
    if isinstance(rv, int) and rv:
        sys.exit(rv)


if __name__ == "__main__":  # pragma: no cover
    main()
