"""Overlap on and off (issue 36): ``navbench all`` wall time on a two-level profile, alternating.

    python docs/data/speed/overlap_ab.py --repeats 3 --workers 2 \\
        --set levels=house-1,house-2 --set views.count=300 --set fit.steps=300 --set tasks.count=6

Each run is a fresh scratch project (a copy of ``levels/`` and ``tasks/``, an empty cache and
database), so every stage computes; the numba cache is shared (nothing compiles). The runs
alternate on, off, on, off, ...; each line gives the wall seconds, the run's own ``wall`` and
stage rows from its breakdown, and ``uptime``'s load before it. The last lines give the medians
and their ratio (off / on).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def load() -> str:
    return Path("/proc/loadavg").read_text().split()[0] if Path("/proc/loadavg").exists() else "?"


def one(overlap: bool, args) -> tuple[float, str]:
    with tempfile.TemporaryDirectory(prefix="overlap-ab-") as d:
        proj = Path(d)
        for sub in ("levels", "tasks"):
            if (ROOT / sub).is_dir():
                shutil.copytree(ROOT / sub, proj / sub)
        env = {**os.environ, "PYTHONPATH": str(ROOT), "NAVBENCH_DB": f"sqlite:///{proj / 'nb.db'}",
               "COLUMNS": "160"}
        cmd = [sys.executable, "-m", "navbench.cli.main", "all", "--profile", args.profile,
               "--workers", str(args.workers), "--report", str(proj / "report"),
               "--overlap" if overlap else "--no-overlap"]
        for s in args.set or ():
            cmd += ["--set", s]
        t0 = time.perf_counter()
        res = subprocess.run(cmd, cwd=proj, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if res.returncode != 0:
            raise SystemExit(f"run failed ({res.returncode}):\n{res.stderr[-3000:]}")
        keep = [ln for ln in res.stdout.splitlines()
                if ln.split("  ")[0].strip() in ("collect-views", "fit-map", "run-navigation", "wall",
                                                 "total", "total (summed)", "fit-map (overlapped)",
                                                 "collect-views (overlapped)")]
        return wall, "\n".join("    " + ln for ln in keep)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--profile", default="quick")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--set", action="append")
    args = ap.parse_args()
    times: dict[bool, list[float]] = {True: [], False: []}
    for i in range(args.repeats):
        for overlap in (True, False) if i % 2 == 0 else (False, True):
            before = load()
            wall, detail = one(overlap, args)
            times[overlap].append(wall)
            print(f"repeat {i + 1} overlap {'on ' if overlap else 'off'}: {wall:7.1f} s  "
                  f"(load {before} before, {load()} after)\n{detail}", flush=True)
    on, off = statistics.median(times[True]), statistics.median(times[False])
    print(f"median on {on:.1f} s, off {off:.1f} s, off/on {off / on:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
