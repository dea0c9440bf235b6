"""The generated reference pages (docs/hooks/navbench_reference.py): every command and option
of the typer app has an entry in the CLI reference, every profile field (and every FitConfig and
EpisodeConfig field a profile may set) a row in the profile-field reference; and the checks that
say so do find a missing entry. These need navbench only, not the docs extra."""

from __future__ import annotations

import re
from types import SimpleNamespace

import pytest

from ._hook import ROOT, load_hook


@pytest.fixture(scope="module")
def hook():
    return load_hook()


@pytest.fixture(scope="module")
def cli_md(hook):
    return hook.render_cli()


@pytest.fixture(scope="module")
def fields_md(hook):
    return hook.render_profile_fields()


def test_every_command_and_option_has_an_entry(hook, cli_md):
    entries = hook.cli_entries()
    # the app as the user sees it: every registered command, the sub-apps' commands too
    assert {"all", "fit-map", "run-navigation", "track-eval", "db-info", "cache-gc"} <= set(entries)
    assert "--steps" in entries["fit-map"] and "--kidnap-every" in entries["track-eval"]
    assert hook.missing_cli_entries(cli_md) == []


def _drop_row(md: str, anchor: str, option: str) -> str:
    head = re.search(rf"^#+ [^\n]*\{{#{re.escape(anchor)}\}}$", md, flags=re.M)
    start = head.end()
    row = re.compile(rf"^\| `{re.escape(option)}`[^\n]*\n", flags=re.M)
    m = row.search(md, start)
    assert m is not None, (anchor, option)
    return md[:m.start()] + md[m.end():]


def test_a_missing_option_or_command_is_reported(hook, cli_md):
    assert hook.missing_cli_entries(_drop_row(cli_md, "fit-map", "--steps")) == ["fit-map --steps"]
    no_heading = re.sub(r"^## navbench track-eval \{#track-eval\}$", "## navbench track-eval", cli_md, flags=re.M)
    assert "command track-eval" in hook.missing_cli_entries(no_heading)


def test_a_new_command_is_documented_without_editing_the_page(hook):
    import typer

    app = typer.Typer()

    @app.command("frobnicate")
    def frobnicate(level: str = typer.Argument(..., help="A level."),
                   count: int = typer.Option(3, "--count", min=1, help="How many.")):
        """Frobnicate a level."""

    @app.command("other")
    def other():
        """Another command (a single-command app has no command names)."""

    md = hook.render_cli(app)
    assert "{#frobnicate}" in md and "Frobnicate a level." in md
    assert re.search(r"^\| `--count` \| int ≥ 1 \| `3` \| How many. \|$", md, flags=re.M), md
    assert hook.missing_cli_entries(md, app) == []


def test_the_hook_fills_the_committed_pages(hook):
    for page, marker in hook.PAGES.items():
        text = (ROOT / "docs" / page).read_text(encoding="utf-8")
        assert marker in text, page
    page = SimpleNamespace(file=SimpleNamespace(src_uri="reference/cli.md"))
    out = hook.on_page_markdown((ROOT / "docs/reference/cli.md").read_text(), page, None, None)
    assert hook.CLI_MARKER not in out and hook.missing_cli_entries(out) == []
    other = SimpleNamespace(file=SimpleNamespace(src_uri="index.md"))
    assert hook.on_page_markdown("x " + hook.CLI_MARKER, other, None, None) == "x " + hook.CLI_MARKER
    with pytest.raises(ValueError, match="must hold the marker"):
        hook.on_page_markdown("# Command line\n", page, None, None)


def test_every_profile_field_has_a_row(hook, fields_md):
    import dataclasses

    from navbench.pipeline.profiles import Profile

    assert hook.missing_profile_entries(fields_md) == []
    assert len(hook.profile_field_rows()) == len(dataclasses.fields(Profile))


def test_a_missing_profile_field_is_reported(hook, fields_md):
    dropped = re.sub(r"^\| `\[fit\] steps`<br>\(`fit_steps`\) \|[^\n]*\n", "", fields_md, flags=re.M)
    assert dropped != fields_md
    assert hook.missing_profile_entries(dropped) == ["Profile.fit_steps"]
    dropped = re.sub(r"^\| `n_samples` \|[^\n]*\n", "", fields_md, flags=re.M)
    assert hook.missing_profile_entries(dropped) == ["FitConfig.n_samples"]


def test_profile_rows_state_default_option_and_check(fields_md):
    rows = {re.search(r"\((`\w+`)\)", r).group(1): r for r in fields_md.splitlines()
            if r.startswith("| `") and "<br>(`" in r}
    assert "`200`" in rows["`fit_steps`"] and "`--steps`" in rows["`fit_steps`"]
    assert "expected an integer in [1, 1000000]" in rows["`fit_steps`"]
    assert "one of ['half', 'paper']" in rows["`camera`"]
    assert "each a known noise level (none, low, mid, high, tracking)" in rows["`noise`"]


def test_describe_check_uses_the_checks_own_words(hook):
    from navbench.pipeline.profiles import FIELDS

    assert hook.describe_check(FIELDS["views"][1]) == "expected an integer in [1, 100000]"
    assert hook.describe_check(FIELDS["scoring_preset"][1]) == \
        "expected a string; one of ['paper', 'nrns', 'habitat']"
    # the profile's own name: one name (the check wraps it in a list), not a list of names
    assert hook.describe_check(FIELDS["name"][1]).startswith("a safe profile name (")


def test_python_api_page_drops_sphinx_roles(hook):
    html = "<p>Runs :func:<code>run_profile</code> and :class:<code>Progress</code>::</p><p>a: b</p>"
    api = SimpleNamespace(file=SimpleNamespace(src_uri="reference/python-api.md"))
    assert hook.on_page_content(html, api, None, None) == \
        "<p>Runs <code>run_profile</code> and <code>Progress</code>:</p><p>a: b</p>"
    other = SimpleNamespace(file=SimpleNamespace(src_uri="tutorials/gpu.md"))
    assert hook.on_page_content(html, other, None, None) == html
