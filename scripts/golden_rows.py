"""Record (or check) the episode rows a small fixed grid stores: the refactoring guard.

    python scripts/golden_rows.py --write tests/fixtures/golden_rows.json   # record
    python scripts/golden_rows.py --check tests/fixtures/golden_rows.json   # compare
    python scripts/golden_rows.py --version navbench-5 --check tests/fixtures/golden_rows_navbench-5.json

The grid: the tiny test level (tests/pipeline/test_stages.py: tiny_level), planned and tracked on
its voxelized true geometry (`map = "true"`; a tiny fit plans nothing),
3 tasks, estimators ours / no-map / dynamics / gt at low and mid noise (24 episodes), run
through the command line (``python -m navbench.cli.main run-navigation``) in a scratch project.
Every stored column except the run id, times and timings is kept, floats as ``repr`` (bit for
bit). The grid runs under one benchmark version, named in its profile (``--version``; default
``navbench-1``, whose rows were recorded from the code before the pipeline-layer refactor, issue
12), so a change of the default version leaves each fixture's grid as it was. One fixture per
guarded version: ``golden_rows.json`` (navbench-1) and ``golden_rows_<version>.json``. Rewrite one
only for an intentional, documented change of results. The profile names its version, so ``--code`` takes
a repository of 2026-11-27 or later (older code has no ``benchmark_version`` key).
"""

from __future__ import annotations

import argparse
import json
import os
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from scripts._env import pythonpath_first  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

PROFILE = """
name = "golden"
benchmark_version = "{version}"
levels = ["tiny"]
[views]
camera = "half"
count = 12
seed = 0
eval_count = 4
eval_seed = 1
[fit]
steps = 3
grid_shape = [16, 12, 8]
n_samples = 40
images_per_batch = 4
pixels_per_image = 50
threads = 1
[tasks]
count = 3
[navigation]
estimators = ["ours", "no-map", "dynamics", "gt"]
noise = ["low", "mid"]
workers = 1
map = "true"
"""

COLUMNS = ("cell_key", "level", "map_key", "task_set_key", "task_id", "estimator", "estimator_options",
           "noise", "seed", "success", "spl_term", "path_length", "optimal_length", "steps",
           "end_reason", "collided", "loc_rmse_m", "rot_rmse_deg", "traj_key")


#: The version whose rows ``tests/fixtures/golden_rows.json`` holds.
GOLDEN_VERSION = "navbench-1"


def fixture_name(version: str = GOLDEN_VERSION) -> str:
    """The fixture file of ``version``'s rows under ``tests/fixtures/``."""
    return "golden_rows.json" if version == GOLDEN_VERSION else f"golden_rows_{version}.json"


def profile_text(version: str = GOLDEN_VERSION) -> str:
    """The grid's profile file under benchmark ``version``."""
    return PROFILE.replace("{version}", version)


def grid_rows(code_root: Path = ROOT, version: str = GOLDEN_VERSION) -> list[dict]:
    """Run the grid under benchmark ``version`` with the navbench package found under
    ``code_root``; the stored rows."""
    sys.path.insert(0, str(code_root))
    from navbench.levelio import save_level
    from tests.pipeline.test_stages import tiny_level

    with tempfile.TemporaryDirectory() as d:
        proj = Path(d)
        (proj / "levels").mkdir()
        save_level(tiny_level(), proj / "levels" / "tiny.json")
        (proj / "golden.toml").write_text(profile_text(version))
        env = {**os.environ, "PYTHONPATH": pythonpath_first(code_root), "NAVBENCH_DB": f"sqlite:///{proj / 'g.db'}"}
        subprocess.run([sys.executable, "-m", "navbench.cli.main", "run-navigation", "--profile", "golden.toml"],
                       cwd=proj, env=env, check=True, capture_output=True, text=True)
        con = sqlite3.connect(proj / "g.db")
        cur = con.execute(f"SELECT {', '.join(COLUMNS)} FROM episodes ORDER BY cell_key, task_id, seed")
        rows = []
        for values in cur.fetchall():
            row = {}
            for k, v in zip(COLUMNS, values):
                row[k] = repr(v) if isinstance(v, float) else (json.loads(v) if k == "estimator_options" else v)
            rows.append(row)
        con.close()
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", type=Path)
    g.add_argument("--check", type=Path)
    ap.add_argument("--code", type=Path, default=ROOT, help="repository whose navbench runs the grid")
    ap.add_argument("--version", default=GOLDEN_VERSION, help="benchmark version of the grid")
    a = ap.parse_args()
    rows = grid_rows(a.code.resolve(), a.version)
    if a.write:
        a.write.write_text(json.dumps(rows, indent=1, sort_keys=True) + "\n")
        print(f"{len(rows)} rows -> {a.write}")
        return 0
    want = json.loads(a.check.read_text())
    diff = [i for i, (x, y) in enumerate(zip(rows, want)) if x != y]
    print(f"{len(rows)} rows, {len(want)} recorded, {len(diff)} differ")
    return 0 if rows == want else 1


if __name__ == "__main__":
    sys.exit(main())
