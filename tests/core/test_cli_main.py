"""The CLI shell: instant help, version, one-line errors."""

import subprocess
import sys

from typer.testing import CliRunner

from navbench import __version__
from navbench.cli.main import app


def test_version():
    r = CliRunner().invoke(app, ["--version"])
    assert r.exit_code == 0
    assert __version__ in r.output


def test_help_does_not_import_heavy_modules():
    code = (
        "import sys; from navbench.cli.main import app\n"
        "from typer.testing import CliRunner\n"
        "r = CliRunner().invoke(app, ['--help']); assert r.exit_code == 0, r.output\n"
        "heavy = [m for m in ('torch', 'numba', 'pymunk') if m in sys.modules]\n"
        "print(','.join(heavy))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_navbench_error_is_one_line(tmp_path, monkeypatch, capsys):
    import pytest

    from navbench.cli import main as cli_main
    from navbench.errors import LevelError

    def boom(*args, **kwargs):
        raise LevelError("levels/x.json: walls[0].thickness: expected a positive number")

    monkeypatch.setattr(cli_main, "app", boom)
    with pytest.raises(SystemExit) as e:
        cli_main.main([])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "walls[0].thickness" in err


def test_exit_code_of_command_is_propagated(monkeypatch):
    import pytest
    import typer

    from navbench.cli import main as cli_main

    sub = typer.Typer()

    @sub.command()
    def fail():
        raise typer.Exit(3)

    @sub.command()
    def other():
        pass

    monkeypatch.setattr(cli_main, "app", sub)
    with pytest.raises(SystemExit) as e:
        cli_main.main(["fail"])
    assert e.value.code == 3
