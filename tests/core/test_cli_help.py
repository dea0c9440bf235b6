"""``navbench <cmd> --help`` shows what each option does by default (issue 12, item 6).

Typer renders help with rich markup, where ``[default: x]`` is a style tag and vanished from
every help: each help string must render intact. Defaults that come from a profile cite the
bundled profiles' values, which must be what :func:`load_profile` (the validated loader, not
the help's own reader) gives. Shell completion is enabled.
"""

from __future__ import annotations

import re

import pytest
import typer
from typer.testing import CliRunner

from navbench.cli.main import app
from navbench.pipeline.profiles import DEFAULT_PROFILE, available_profiles, load_profile

_BOX = re.compile(r"[│╭╮╰╯─┃━┏┓┗┛]")


def _norm(text: str) -> str:
    """``text`` without the help boxes' borders, its whitespace collapsed (wrapping undone)."""
    return " ".join(_BOX.sub(" ", text).split())


def _commands() -> list[tuple[tuple[str, ...], object]]:
    """``(path, click command)`` of every command and group of the app, the root excluded."""
    out = []

    def walk(cmd, path):
        for name, sub in getattr(cmd, "commands", {}).items():
            out.append(((*path, name), sub))
            walk(sub, (*path, name))

    walk(typer.main.get_command(app), ())
    return out


COMMANDS = _commands()
IDS = [" ".join(p) for p, _ in COMMANDS]


def _render(*args: str) -> str:
    # wide enough that nothing is cut short with an ellipsis; wrapping is undone by _norm
    r = CliRunner().invoke(app, [*args, "--help"], prog_name="navbench", env={"COLUMNS": "400"})
    assert r.exit_code == 0, r.output
    return r.output


def _shown(help_text: str) -> str:
    """What a reader must see of a help string: its escaped brackets as brackets."""
    return help_text.replace("\\[", "[")


def _param(path: tuple[str, ...], opt: str):
    cmd = dict(COMMANDS)[path]
    return next(p for p in cmd.params if opt in (*p.opts, p.name))


def test_every_command_is_covered():
    names = {p[0] for p, _ in COMMANDS}
    assert {"all", "fit-map", "collect-views", "run-navigation", "track-eval", "bench", "db"} <= names


@pytest.mark.parametrize("path,cmd", COMMANDS, ids=IDS)
def test_help_strings_render_intact(path, cmd):
    """Every option's and argument's help, defaults included, appears as written."""
    rendered = _norm(_render(*path))
    for p in cmd.params:
        if getattr(p, "help", None):
            assert _norm(_shown(p.help)) in rendered, (p.name, p.help)
    if cmd.help:  # the first paragraph of the command's docstring, on one line
        assert _norm(_shown(cmd.help.split("\n\n")[0])) in rendered


DEFAULT_HELPS = [(path, p.name) for path, cmd in COMMANDS for p in cmd.params
                 if "default:" in (getattr(p, "help", None) or "")]


def test_there_are_defaults_to_check():
    assert len(DEFAULT_HELPS) >= 29  # the issue counted 29 help strings that lost their default


@pytest.mark.parametrize("path,name", DEFAULT_HELPS, ids=[f"{' '.join(p)} {n}" for p, n in DEFAULT_HELPS])
def test_default_is_visible(path, name):
    """Every ``[default: ...]`` written in a help string is in the rendered help, brackets and all."""
    help_text = _shown(_param(path, name).help)
    cited = re.findall(r"\[default: .*?\](?=\.|$)", help_text)
    assert cited, f"{name}: write the default as [default: ...] (escaped, see navbench.cli._help)"
    rendered = _norm(_render(*path))
    for c in cited:
        assert _norm(c) in rendered


def _profile_values(help_text: str) -> dict[str, str]:
    """``{profile: value}`` from ``[default: the profile's (quick and six: 2000; paper: 10000)]``."""
    m = re.search(r"\[default: the profile's \((.*)\)(, else [^\]]*)?\]", _shown(help_text))
    assert m, help_text
    out = {}
    for group in m.group(1).split("; "):
        names, value = group.split(": ", 1)
        for n in re.split(r", | and ", names):
            out[n] = value
    return out


def _as_cited(v) -> str:
    return ", ".join(map(str, v)) if isinstance(v, (list, tuple)) else str(v)


#: (command, option, Profile field) of the defaults that come from the profile
PROFILE_DEFAULTS = [
    (("fit-map",), "--steps", "fit_steps"), (("fit-map",), "--seed", "fit_seed"),
    (("fit-map",), "--camera", "camera"),
    (("collect-views",), "--count", "views"), (("collect-views",), "--seed", "views_seed"),
    (("collect-views",), "--camera", "camera"),
    (("collect-5000-views",), "--seed", "views_seed"), (("collect-5000-views",), "--camera", "camera"),
    (("run-navigation",), "levels", "levels"), (("run-navigation",), "--estimators", "estimators"),
    (("run-navigation",), "--noise", "noise"), (("run-navigation",), "--tasks", "tasks"),
    (("run-navigation",), "--seeds", "seeds"), (("run-navigation",), "--workers", "workers"),
    (("run-navigation",), "--map", "map_source"), (("all",), "--workers", "workers"),
]


@pytest.mark.parametrize("path,opt,field", PROFILE_DEFAULTS, ids=[f"{p[0]} {o}" for p, o, _ in PROFILE_DEFAULTS])
def test_profile_defaults_cite_every_bundled_profile(path, opt, field):
    cited = _profile_values(_param(path, opt).help)
    expected = {name: _as_cited(getattr(load_profile(name), field)) for name in available_profiles()}
    assert cited == expected


def test_quick_profile_numbers_where_the_help_cites_them():
    """The issue's stale numbers: fit-map said quick fits 1500 steps, collect-views 1000 views."""
    quick = load_profile("quick")
    steps = _norm(_render("fit-map"))
    views = _norm(_render("collect-views"))
    assert re.search(rf"Adam steps \[default: the profile's \([^)]*quick[^)]*: {quick.fit_steps}[;)]", steps)
    assert re.search(rf"Number of views \[default: the profile's \([^)]*quick[^)]*: {quick.views}[;)]", views)
    assert "1500" not in steps and "quick 1000" not in views


def test_fit_device_default_names_the_fallback():
    assert "[default: the profile's" in _shown(_param(("fit-map",), "--device").help)
    assert "else auto]" in _shown(_param(("fit-map",), "--device").help)


PROFILE_OPTIONS = [path for path, cmd in COMMANDS if any("--profile" in p.opts for p in cmd.params)]


def test_profile_options_found():
    assert {("all",), ("fit-map",), ("collect-views",), ("collect-5000-views",),
            ("run-navigation",)} <= set(PROFILE_OPTIONS)


@pytest.mark.parametrize("path", PROFILE_OPTIONS, ids=[" ".join(p) for p in PROFILE_OPTIONS])
def test_profile_help_names_every_bundled_profile(path):
    bundled = available_profiles()
    assert {"quick", "paper", "six"} <= set(bundled)
    p = _param(path, "--profile")
    help_text = _shown(p.help)
    for name in bundled:
        assert re.search(rf"\b{name}\b", help_text), (name, help_text)
    assert ".toml path" in help_text
    # the default profile is named: by typer for a literal default, else by the help itself
    default_shown = f"[default: {DEFAULT_PROFILE}]"
    assert p.default == DEFAULT_PROFILE or default_shown in help_text
    assert default_shown in _norm(_render(*path))


def test_db_default_is_the_database_modules():
    from navbench.cli._help import DB_URL
    from navbench.results.db import DEFAULT_DB_URL

    assert DB_URL == DEFAULT_DB_URL


def test_completion_is_enabled(monkeypatch):
    """``--show-completion`` prints the script for the shell typer detects from the parent
    processes (its ``bash`` argument is not read); a suite started from a background job has
    no shell among its parents, so the detection is pinned to bash here."""
    import typer.completion

    monkeypatch.setattr(typer.completion, "_get_shell_name", lambda: "bash")
    root = _norm(CliRunner().invoke(app, ["--help"], prog_name="navbench", env={"COLUMNS": "400"}).output)
    assert "--install-completion" in root and "--show-completion" in root
    r = CliRunner().invoke(app, ["--show-completion", "bash"], prog_name="navbench")
    assert r.exit_code == 0
    assert "_NAVBENCH_COMPLETE=complete_bash" in r.output
    assert "complete -o default -F _navbench_completion navbench" in r.output


def test_completion_completes_commands_and_options():
    env = {"_NAVBENCH_COMPLETE": "complete_bash", "COMP_WORDS": "navbench fit-", "COMP_CWORD": "1"}
    r = CliRunner().invoke(app, [], prog_name="navbench", env=env)
    assert r.output.split() == ["fit-map"]
    env = {**env, "COMP_WORDS": "navbench fit-map --pro", "COMP_CWORD": "2"}
    r = CliRunner().invoke(app, [], prog_name="navbench", env=env)
    assert r.output.split() == ["--profile"]


def test_console_entry_point_prints_the_completion_script():
    """``navbench --show-completion`` through :func:`navbench.cli.main.main`, as installed, run
    from bash (typer detects the shell among the parent processes; ``; true`` keeps bash from
    replacing itself with the command, so it stays the parent even in a background job)."""
    import shlex
    import subprocess
    import sys

    code = "import sys; sys.argv[0] = 'navbench'; from navbench.cli.main import main; main()"
    cmd = f"{shlex.quote(sys.executable)} -c {shlex.quote(code)} --show-completion; true"
    p = subprocess.run(["bash", "-c", cmd], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert "complete -o default -F _navbench_completion navbench" in p.stdout


@pytest.mark.parametrize("path,cmd", COMMANDS, ids=IDS)
def test_command_description_is_filled_not_ragged(path, cmd):
    """A docstring's source line breaks do not show: at 80 columns every line of a paragraph but
    its last is nearly full (typer keeps single line breaks in rich mode; main.py reflows)."""
    r = CliRunner().invoke(app, [*path, "--help"], prog_name="navbench", env={"COLUMNS": "80"})
    lines = r.output.splitlines()
    start = next(i for i, s in enumerate(lines) if "Usage:" in s) + 1
    end = next((i for i, s in enumerate(lines) if s.lstrip().startswith("╭")), len(lines))
    paragraphs = "\n".join(s.rstrip() for s in lines[start:end]).strip("\n").split("\n\n")
    for para in paragraphs:
        for line in para.splitlines()[:-1]:
            assert len(line) >= 60, (line, para)
