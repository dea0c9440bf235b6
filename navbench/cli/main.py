"""The ``navbench`` typer app.

Each module in :mod:`navbench.cli.commands` defines ``register(app)`` and adds its command(s);
they are discovered here so that commands never edit this file. Command modules import only
light modules at import time (typer, rich, the standard library): torch, numba and pymunk are
imported inside the command functions, so ``navbench --help`` answers at once.

Errors derived from :class:`navbench.errors.NavbenchError` are printed as one line on stderr
with exit code 2; anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import sys

import typer

from navbench import __version__

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


_register_all()
_reflow_help(app)


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


def main(argv: list[str] | None = None) -> None:
    """Console entry point: run the app, turning NavbenchError into a one-line message and
    usage errors into click's short usage message (exit 2)."""
    from navbench.errors import NavbenchError

    try:
        rv = app(args=argv, standalone_mode=False)
    except NavbenchError as e:
        # typer.secho prints the text as is (no rich markup: user text may hold "[/x]")
        typer.secho(f"error: {e}", err=True, fg=typer.colors.RED)
        sys.exit(2)
    except KeyboardInterrupt:
        typer.secho("interrupted", err=True, fg=typer.colors.YELLOW)
        sys.exit(130)
    except Exception as e:
        kind = _click_kind(e)
        if kind == "Exit":
            sys.exit(e.exit_code)
        if kind == "Abort":
            typer.secho("aborted", err=True)
            sys.exit(1)
        if kind == "ClickException":  # usage errors (bad option, value out of range, missing argument)
            e.show()
            sys.exit(e.exit_code)
        raise
    # with standalone_mode=False, click returns typer.Exit(n)'s code (and 1 after Ctrl-C)
    if isinstance(rv, int) and rv:
        sys.exit(rv)


if __name__ == "__main__":  # pragma: no cover
    main()
