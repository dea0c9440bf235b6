"""The documentation site builds with ``mkdocs build --strict`` (what ``make docs`` runs), so a
broken link, a missing anchor, a page left out of the navigation or a navigation entry without
its page fails the test suite; and the built reference pages hold every command, option and
profile field. Skipped, with the reason, only where the docs extra (mkdocs, mkdocs-material,
mkdocstrings) cannot be imported: ``pip install -e '.[docs]'`` (``make setup`` installs it)."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from scripts._env import pythonpath_first

from ._hook import ROOT, load_hook

MISSING = [m for m in ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python")
           if importlib.util.find_spec(m.split(".")[0]) is None
           or (m == "mkdocstrings_handlers.python" and importlib.util.find_spec(m) is None)]
pytestmark = pytest.mark.skipif(
    bool(MISSING), reason=f"the docs extra is not installed (missing {', '.join(MISSING)}): "
                          "pip install -e '.[docs]'")


def mkdocs_build(config: Path, site: Path, timeout: int = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=pythonpath_first(ROOT), NO_MKDOCS_2_WARNING="1")
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config),
                           "--site-dir", str(site)], cwd=config.parent, env=env,
                          capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    site = tmp_path_factory.mktemp("site")
    p = mkdocs_build(ROOT / "mkdocs.yml", site)
    warnings = [line for line in (p.stdout + p.stderr).splitlines() if "WARNING" in line or "ERROR" in line]
    assert p.returncode == 0, "mkdocs build --strict failed:\n" + "\n".join(warnings or [p.stderr[-4000:]])
    return site


def test_strict_build_passes(site):
    assert (site / "index.html").is_file()
    assert (site / "reference" / "cli" / "index.html").is_file()


def test_built_cli_page_has_every_command_and_option(site):
    html = (site / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    for anchor, names in load_hook().cli_entries().items():
        assert f'id="{anchor}"' in html, anchor
        section = html.split(f'id="{anchor}"', 1)[1]
        for n in names:
            assert f"<code>{n}</code>" in section, (anchor, n)


def test_built_profile_page_has_every_field(site):
    import dataclasses

    from navbench.pipeline.profiles import Profile

    html = (site / "reference" / "profile-fields" / "index.html").read_text(encoding="utf-8")
    for f in dataclasses.fields(Profile):
        assert f"<code>{f.name}</code>" in html, f.name


def test_strict_fails_on_broken_links_and_unlisted_pages(tmp_path):
    """The validation settings of mkdocs.yml, on a two-page site: a link to a missing page, a
    missing anchor, a page not in the navigation and a folder link each fail the strict build;
    a link to a data file (docs/data/...) passes."""
    import yaml

    ours = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    docs = tmp_path / "docs"
    (docs / "data" / "x").mkdir(parents=True)
    (docs / "data" / "x" / "env.txt").write_text("data\n")
    (docs / "data" / "x" / "rows.json").write_text("{}\n")
    (docs / "orphan.md").write_text("# Orphan\n")
    (docs / "index.md").write_text("# Home\n\n[ok](data/x/env.txt) [ok](data/x/rows.json) [ok](#home)\n")
    config = {"site_name": "t", "docs_dir": "docs", "validation": ours["validation"],
              "markdown_extensions": ["attr_list", {"toc": {"permalink": True}}],
              "nav": [{"Home": "index.md"}]}
    cfg = tmp_path / "mkdocs.yml"
    cfg.write_text(yaml.safe_dump(config))
    p = mkdocs_build(cfg, tmp_path / "site1", timeout=120)
    out = p.stdout + p.stderr
    assert p.returncode == 1 and "orphan.md" in out, out  # a page left out of the navigation
    config["nav"].append({"Orphan": "orphan.md"})
    cfg.write_text(yaml.safe_dump(config))
    assert mkdocs_build(cfg, tmp_path / "site2", timeout=120).returncode == 0  # data-file links pass
    for bad in ("[x](missing.md)", "[x](#no-such-anchor)", "[x](data/x/)", "[x](orphan.md#nope)"):
        (docs / "index.md").write_text(f"# Home\n\n{bad}\n")
        p = mkdocs_build(cfg, tmp_path / "site3", timeout=120)
        assert p.returncode == 1 and re.search(r"WARNING", p.stdout + p.stderr), (bad, p.stdout + p.stderr)
