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
import pkgutil
import sys

import typer

from navbench import __version__

app = typer.Typer(
    name="navbench",
    help="Reproduce 'Tracking and Planning with Spatial World Models': levels, simulator, "
    "world models, navigation and tracking experiments with a results database.",
    no_args_is_help=True,
    add_completion=False,
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


_register_all()


def _click_types() -> tuple[tuple[type, ...], tuple[type, ...], tuple[type, ...]]:
    """``(ClickException, Exit, Abort)`` classes of click and of typer's vendored copy of click
    (typer >= 0.29 raises its own ``typer._click.exceptions`` classes, which are not click's)."""
    import click

    exc, exits, aborts = [click.ClickException], [typer.Exit, click.exceptions.Exit], [typer.Abort, click.Abort]
    try:
        from typer._click import exceptions as vendored

        exc.append(vendored.ClickException)
        for name, bucket in (("Exit", exits), ("Abort", aborts)):
            if hasattr(vendored, name):
                bucket.append(getattr(vendored, name))
    except ImportError:  # an older typer that uses click itself
        pass
    return tuple(exc), tuple(exits), tuple(aborts)


def main(argv: list[str] | None = None) -> None:
    """Console entry point: run the app, turning NavbenchError into a one-line message and
    usage errors into click's short usage message (exit 2)."""
    from navbench.errors import NavbenchError

    click_errors, exits, aborts = _click_types()
    try:
        rv = app(args=argv, standalone_mode=False)
    except NavbenchError as e:
        # typer.secho prints the text as is (no rich markup: user text may hold "[/x]")
        typer.secho(f"error: {e}", err=True, fg=typer.colors.RED)
        sys.exit(2)
    except KeyboardInterrupt:
        typer.secho("interrupted", err=True, fg=typer.colors.YELLOW)
        sys.exit(130)
    except exits as e:
        sys.exit(e.exit_code)
    except aborts:
        typer.secho("aborted", err=True)
        sys.exit(1)
    except click_errors as e:  # usage errors (bad option, value out of range, missing argument)
        e.show()
        sys.exit(e.exit_code)
    # with standalone_mode=False, click returns typer.Exit(n)'s code (and 1 after Ctrl-C)
    if isinstance(rv, int) and rv:
        sys.exit(rv)


if __name__ == "__main__":  # pragma: no cover
    main()
