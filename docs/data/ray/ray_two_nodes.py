"""Run a small navigation grid on a two-node Ray cluster on this machine and compare its stored
rows with the local executor's, bit for bit (issue 17).

    python docs/data/ray/ray_two_nodes.py                       # starts and stops its own two nodes
    python docs/data/ray/ray_two_nodes.py --address HOST:PORT   # a cluster started by hand (ray start)
    python docs/data/ray/ray_two_nodes.py --sim vizdoom         # the episodes on the engine (issue 37)

The grid is the refactoring guard's (scripts/golden_rows.py: the tiny level on its true
geometry, ours / no-map / dynamics / gt at low and mid noise, 3 tasks: 24 episodes). It runs
twice (``--sim vizdoom``: on the ViZDoom engine, an engine process per episode on whichever
node runs it), each time in its own scratch project (so the second run cannot take the first one's
trajectories from the cache): with ``--executor local --workers 2`` and with ``--executor ray
--address ...``. Without ``--address`` the script starts a head node and a worker node (one CPU
each, two raylets: :class:`ray.cluster_utils.Cluster`, the same processes ``ray start --head``
and ``ray start --address`` start) and shuts exactly those down at the end. It prints the rows
compared, the nodes the cluster had and which nodes ran chunks, and exits 1 if any row differs.

Ray workers import navbench from the environment the nodes were started in: start ``ray start``
with this repository on ``PYTHONPATH`` (or navbench installed), and give every node the cache
directory at the same path (here: one machine; across machines a shared filesystem).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from scripts._env import pythonpath_first  # noqa: E402
from scripts.golden_rows import COLUMNS, profile_text  # noqa: E402


def scratch_project(where: Path) -> Path:
    from navbench.levelio import save_level
    from tests.pipeline.test_stages import tiny_level

    where.mkdir(parents=True)
    (where / "levels").mkdir()
    save_level(tiny_level(), where / "levels" / "tiny.json")
    (where / "golden.toml").write_text(profile_text())  # the golden grid, under navbench-1
    return where


def run_grid(proj: Path, *args: str) -> list[tuple]:
    env = {**os.environ, "PYTHONPATH": pythonpath_first(ROOT), "NAVBENCH_DB": f"sqlite:///{proj / 'g.db'}",
           "RAY_ENABLE_UV_RUN_RUNTIME_ENV": "0"}
    res = subprocess.run([sys.executable, "-m", "navbench.cli.main", "run-navigation", "--profile",
                          "golden.toml", *args], cwd=proj, env=env, capture_output=True, text=True)
    if res.returncode != 0:
        raise SystemExit(f"run-navigation {' '.join(args)} failed:\n{res.stdout}\n{res.stderr}")
    with sqlite3.connect(proj / "g.db") as con:
        return con.execute(f"SELECT {', '.join(COLUMNS)} FROM episodes ORDER BY cell_key, task_id, seed").fetchall()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--address", help="a running Ray cluster (default: start a head and a worker node here)")
    ap.add_argument("--sim", default="pymunk", choices=("pymunk", "vizdoom"), help="the simulator of the episodes")
    a = ap.parse_args()
    sim = ("--sim", a.sim)
    os.environ["PYTHONPATH"] = str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")
    os.environ.setdefault("NUMBA_CACHE_DIR", str(ROOT / ".numba_cache"))
    if a.address:  # a wrong address fails now, not after the local run
        from navbench.errors import NavbenchError
        from navbench.pipeline.executor import check_reachable

        try:
            check_reachable(a.address)
        except NavbenchError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
    tmp = Path(tempfile.mkdtemp(prefix="navbench-ray-"))
    cluster = None
    try:
        local = run_grid(scratch_project(tmp / "local"), *sim, "--executor", "local", "--workers", "2")
        address = a.address
        if address is None:
            from ray.cluster_utils import Cluster

            cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "include_dashboard": False,
                                                                    "object_store_memory": 100 * 2**20})
            cluster.add_node(num_cpus=1, object_store_memory=100 * 2**20)
            cluster.wait_for_nodes()
            address = cluster.address
        import ray

        ray.init(address=address, log_to_driver=False)
        nodes = [n["NodeID"][:8] for n in ray.nodes() if n["Alive"]]
        ray.shutdown()
        remote = run_grid(scratch_project(tmp / "ray"), *sim, "--executor", "ray", "--address", address)
        same = local == remote
        print(f"ray cluster at {address}: {len(nodes)} nodes ({', '.join(nodes)})")
        print(f"simulator: {a.sim}")
        print(f"{len(local)} rows with --executor local --workers 2, {len(remote)} with --executor ray; "
              f"identical: {same}")
        return 0 if same and len(local) == 24 else 1
    finally:
        if cluster is not None:
            cluster.shutdown()
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
