"""The hostile-input generator (:mod:`tests.bad_input.fuzz`) against the invariant of issue 34.

For every generated case, in a fresh copy of a small project:

- exit status 2 (0 only for a damaged file that may still be valid), no traceback, and one
  line on stderr: ``error: ...`` naming the damaged file or option (or click's short usage
  message for an option typer itself refuses);
- a library call (for the formats read by stages: task sets, manifests, refs, map and views
  files) returns or raises a :class:`~navbench.errors.NavbenchError` of one line naming the file;
- no file written outside the outputs the command names, nothing that was there removed or
  changed, and no row added to any table of the results database (nothing scored, no run);
- no hang: each case has 60 s (a FIFO opened for reading would block for ever).

``make test`` runs one case per generator (154 cases: ~10 s in one process, ~30 s with -n 2). More:
``NAVBENCH_FUZZ_CASES=2000 python -m pytest -q -n 2 tests/bad_input/test_fuzz.py``
(``NAVBENCH_FUZZ_SEED`` picks another seeded draw). A failure names its case index and
generator; rerun one with ``-k 'case-17-'``.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from tests.bad_input import fuzz
from tests.bad_input.conftest import (TINY_PROFILE, db_row_counts, deadline, nb, removed_or_changed,
                                      tree_snapshot)

N_CASES = int(os.environ.get("NAVBENCH_FUZZ_CASES", len(fuzz.GENERATORS)))
SEED = int(os.environ.get("NAVBENCH_FUZZ_SEED", "0"))
CASE_TIMEOUT_S = 60


@pytest.fixture(scope="module")
def base_project(tmp_path_factory):
    """The project every case copies: a tiny level, its profile, a task file, a TUM sequence,
    a map file, a views file, a cache with an imported views artifact, an empty results DB."""
    import numpy as np

    from navbench.levelio import save_level
    from navbench.pipeline.cache import ArtifactStore
    from navbench.results.db import ResultsDB
    from navbench.worldmodel.grid import grid_for_level, voxelize_level
    from tests.bad_input.test_views import make_tum
    from tests.pipeline.test_stages import tiny_level

    root = tmp_path_factory.mktemp("fuzzbase")
    proj = root / "proj"
    (proj / "levels").mkdir(parents=True)
    (root / "outside").mkdir()
    level = tiny_level()
    save_level(level, proj / "levels" / "tiny.json")
    (proj / "tiny.toml").write_text(TINY_PROFILE)
    make_tum(root / "tum")
    old = os.getcwd()
    os.chdir(proj)
    try:
        for argv in (["sample-tasks", "tiny", "--count", "3"],
                     ["import-views", str(root / "tum"), "--out", "v.npz", "--store"]):
            res = nb(*argv)
            assert res.code == 0, res.output
        voxelize_level(level, grid_for_level(level, shape=(24, 20, 8))).save(proj / "m.npz")
        with ResultsDB(f"sqlite:///{proj / 'results' / 'navbench.db'}"):
            pass
    finally:
        os.chdir(old)
    arts = ArtifactStore(proj / "results" / "cache").ls("import-views")
    assert len(arts) == 1 and np.load(proj / "v.npz") is not None
    return root, {"views_artifact": (arts[0].stage, arts[0].key)}




def _snapshot(root: Path) -> dict:
    """:func:`tree_snapshot`, with a database file compared by its rows (every user table),
    not its bytes: opening the results database touches the file, and a run row that is
    inserted and deleted again (a refused input) changes pages but no row."""
    import sqlite3

    snap = tree_snapshot(root)
    for p in snap:
        if p.endswith(".db"):
            with sqlite3.connect(f"file:{root / p}?mode=ro", uri=True) as con:
                tables = [t for (t,) in con.execute("SELECT name FROM sqlite_master WHERE type='table' "
                                                    "AND name NOT LIKE 'sqlite_%' ORDER BY name")]
                snap[p] = tuple((t, tuple(sorted(map(repr, con.execute(f'SELECT * FROM "{t}"')))))
                                for t in tables)
    return snap


def _allowed(path: str, case: fuzz.Case) -> bool:
    if any(path == o.rstrip("/") or path.startswith(o if o.endswith("/") else o + "/") or path == o
           for o in (f"proj/{o}" for o in case.outputs)):
        return True
    return case.cache_may_change and path.startswith("proj/results/cache/")


def _one_line(res, names) -> str | None:
    """Why ``res`` breaks the one-line rule, else None."""
    if "Traceback" in res.output:
        return "traceback"
    if res.code != 2:
        return f"exit {res.code}"
    lines = [ln for ln in res.err.splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith("error:")]
    if len(errors) == 1:
        missing = [n for n in names if n not in errors[0]]
        return f"{missing} not named in {errors[0]!r}" if missing else None
    if "Usage:" in res.output and "Error" in res.output and len(res.output.splitlines()) <= 12:
        return None
    return f"not one line: {res.err[-600:]!r}"


@pytest.mark.parametrize("k, name", fuzz.cases(N_CASES, SEED),
                         ids=[f"case-{k}-{n}" for k, n in fuzz.cases(N_CASES, SEED)])
def test_generated_bad_input_keeps_the_invariant(base_project, tmp_path, monkeypatch, k, name):
    from navbench.errors import NavbenchError

    base, info = base_project
    root = tmp_path / "case"
    shutil.copytree(base, root, symlinks=True)
    proj = root / "proj"
    monkeypatch.chdir(proj)
    monkeypatch.delenv("NAVBENCH_DB", raising=False)
    ctx = fuzz.Ctx(root, proj, info)
    case = fuzz.build(k, name, ctx, SEED)
    before, rows = _snapshot(root), db_row_counts(proj)
    with deadline(CASE_TIMEOUT_S):
        if case.argv is not None:
            res = nb(*case.argv)
            problem = None if (res.code == 0 and case.may_pass) else _one_line(res, case.names)
            detail = res.output[-1500:]
        else:
            problem, detail = None, ""
            try:
                case.call()
            except NavbenchError as e:
                msg = str(e)
                if "\n" in msg or not msg.strip():
                    problem = f"not one line: {msg!r}"
                elif any(n not in msg for n in case.names):
                    problem = f"{case.names} not named in {msg!r}"
            except Exception as e:  # noqa: BLE001 - exactly what the generator looks for
                import traceback

                problem, detail = f"{type(e).__name__}: {e}"[:500], "".join(traceback.format_exception(e))[-2000:]
            else:
                if not case.may_pass:
                    problem = "accepted"
    assert problem is None, f"case {k} ({case.label}): {problem}\n{detail}"
    after = _snapshot(root)
    lost = [p for p in removed_or_changed(before, after) if not _allowed(p, case)]
    assert not lost, f"case {k} ({case.label}): removed or changed {lost[:5]}"
    new = [p for p in after if p not in before and not _allowed(p, case)]
    assert not new, f"case {k} ({case.label}): wrote outside its outputs: {new[:5]}"
    assert db_row_counts(proj) == rows, f"case {k} ({case.label}): rows added to the results DB"
