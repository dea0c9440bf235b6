"""Two writers of one user path at once (issue 34): exactly one wins, the other says "exists" in
one line, and the file holds the winner's output whole. The race is made deterministic: the
"other process" runs its whole command while the first is writing (before it publishes)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from navbench.worldmodel.views import load_views, views_content_hash
from tests.bad_input.conftest import assert_clean_error, nb
from tests.bad_input.test_own_views import seq  # noqa: F401 - a fixture


@pytest.fixture
def seq2(project):
    """Another sequence (9 views, seed 5) of the tiny level as TUM RGB-D."""
    from navbench.geometry import Intrinsics
    from navbench.levelio import load_level
    from navbench.worldmodel.tum import export_views
    from navbench.worldmodel.views import collect_views

    v = collect_views(load_level(project / "levels" / "tiny.json"), 9,
                      Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0), seed=5)
    return export_views(v, project.parent / "seq2")


def _race(monkeypatch, module, name, other_args):
    """Patch ``module.name`` (a writer) so that its first call first runs ``navbench
    other_args`` to the end (the other process winning the race); returns that result list."""
    real = getattr(module, name)
    calls, other = [], []

    def writer(*a, **k):
        calls.append(1)
        if len(calls) == 1:
            other.append(nb(*other_args))
        return real(*a, **k)

    monkeypatch.setattr(module, name, writer)
    return other


@pytest.mark.parametrize("out", ["same.npz", "same"])
def test_two_import_views_to_one_out_one_wins_whole(project, seq, seq2, monkeypatch, out):
    import navbench.worldmodel.views as views_mod

    other = _race(monkeypatch, views_mod, "save_views", ["import-views", seq2, "--out", out])
    res = nb("import-views", seq, "--out", out)
    assert other and other[0].code == 0, other[0].output
    assert_clean_error(res, f"--out {out}", "exists")
    got = load_views(project / out)
    assert len(got) == 9  # the winner's sequence, whole (not a mix, not the loser's)
    want = views_content_hash(load_views(_imported(project, seq2)))
    assert views_content_hash(got) == want
    assert not [p for p in project.iterdir() if p.name.startswith(".same")]  # no temp left


def _imported(project, tum):
    res = nb("import-views", tum, "--out", str(project.parent / "ref.npz"))
    assert res.code == 0, res.output
    return project.parent / "ref.npz"


def test_two_export_views_to_one_dir_one_wins_whole(project, seq, seq2, monkeypatch):
    import navbench.worldmodel.tum as tum_mod

    a, b = _imported(project, seq), project.parent / "b.npz"
    assert nb("import-views", seq2, "--out", b).code == 0
    other = _race(monkeypatch, tum_mod, "export_views", ["export-views", b, "out"])
    res = nb("export-views", a, "out")
    assert other[0].code == 0, other[0].output
    assert_clean_error(res, "DIR out", "exists")
    assert len((project / "out" / "rgb.txt").read_text().splitlines()) == 2 + 9


def test_two_real_processes_import_one_out(project, seq, seq2):
    """Two processes started together: one writes, the other is refused (by the up-front check or,
    when they overlap, by the publish step); the file is one whole sequence."""
    procs = [subprocess.Popen([sys.executable, "-m", "navbench.cli.main", "import-views", str(s),
                               "--out", "race.npz"], cwd=project, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for s in (seq, seq2)]
    codes = [p.wait(timeout=300) for p in procs]
    errs = [p.stderr.read() for p in procs]
    assert sorted(codes) == [0, 2], errs
    assert "exists" in errs[codes.index(2)]
    assert len(load_views(project / "race.npz")) in (9, 12)
