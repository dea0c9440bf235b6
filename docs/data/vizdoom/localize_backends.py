"""Issue 37 §3: the localisation study (``navbench localize-eval``) on house-1 on both backends,
paired query by query.

The same ``--seed`` draws the same query poses on both simulators (the engine then places each
to the whole centimetre and 1/65536 turn and its pose is the truth), so query *i* is one place
seen by two cameras. Runs every (frames, map) pair of {pymunk, vizdoom} frames and {the quick
profile's map fitted on pymunk views, the vizdoom-quick map fitted on the engine's views, the
true geometry}, through the CLI (one results database and cache of its own), then prints each
study's figures and the paired differences (vizdoom frames − pymunk frames on one map; engine
map − pymunk map on one camera): mean of the per-query difference in 50 cm recall and in
location error (median), 95 % bootstrap intervals over the queries, and how many queries only
one side found.

``python docs/data/vizdoom/localize_backends.py OUT_DIR PYMUNK_MAP VIZDOOM_MAP [QUERIES]``

``PYMUNK_MAP``: the quick profile's ``map.npz`` (fit-map key 7c35c7f715e1…), ``VIZDOOM_MAP``:
vizdoom-quick's (0c9dea581bcf…, ``navbench fit-map house-1 --profile vizdoom-quick``). Besides the
map files, the vizdoom study is also run as a user would (``--map fit --profile vizdoom-quick``,
which must fit nothing and give the same estimates as the map file).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def run(out: Path, sim: str, map_args: list[str], queries: int) -> dict:
    env = {**os.environ, "NAVBENCH_DB": f"sqlite:///{out / 'loc.db'}", "NAVBENCH_CACHE": str(out / "cache")}
    cmd = ["navbench", "localize-eval", "house-1", *map_args, "--queries", str(queries), "--sim", sim, "--json"]
    t0 = time.time()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if p.returncode:
        sys.exit(f"{' '.join(cmd)}: rc {p.returncode}\n{p.stderr[-2000:]}")
    res = json.loads(p.stdout)
    key = res["meta"]["study_key"]
    with np.load(next((out / "cache" / "localize-eval" / key).glob("*.npz"))) as z:
        arr = {k: z[k] for k in ("true", "est", "query_ms")}
    print(f"$ {' '.join(cmd)}  # {time.time() - t0:.0f} s, study {key[:12]}, map {res['meta']['map_key'][:12]}",
          flush=True)
    return {"summary": res, **arr}


def errors(r: dict) -> tuple[np.ndarray, np.ndarray]:
    d = r["est"] - r["true"]
    h = np.degrees(np.abs((d[:, 2] + np.pi) % (2 * np.pi) - np.pi))
    return np.hypot(d[:, 0], d[:, 1]), h


def paired(a: dict, b: dict, label: str, rng) -> None:
    """``b − a`` per query: 50 cm recall, 50 cm and 10 deg recall, location error."""
    ea, ha = errors(a)
    eb, hb = errors(b)
    assert np.abs(a["true"][:, :2] - b["true"][:, :2]).max() <= 0.0051  # the same places
    ra, rb = (ea <= 0.5).astype(float), (eb <= 0.5).astype(float)
    sa, sb = ((ea <= 0.5) & (ha <= 10)).astype(float), ((eb <= 0.5) & (hb <= 10)).astype(float)
    idx = rng.integers(0, len(ea), (10000, len(ea)))

    def ci(d, stat=np.mean):
        boot = stat(d[idx], axis=1)
        return f"{stat(d):+.3f} [{np.percentile(boot, 2.5):+.3f}, {np.percentile(boot, 97.5):+.3f}]"

    print(f"{label}: recall50 {ci(rb - ra)}, recall50+10deg {ci(sb - sa)}, "
          f"loc err median of differences (m) {ci(eb - ea, np.median)}; "
          f"found only by the first {int(np.sum((ra == 1) & (rb == 0)))}, only by the second "
          f"{int(np.sum((ra == 0) & (rb == 1)))}, by both {int(np.sum((ra == 1) & (rb == 1)))}, "
          f"by neither {int(np.sum((ra == 0) & (rb == 0)))} of {len(ea)}")


def main(out: str, pymunk_map: str, vizdoom_map: str, queries: int = 50) -> None:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    maps = {"pymunk map": ["--map", pymunk_map], "vizdoom map": ["--map", vizdoom_map], "true": ["--map", "true"]}
    res = {(sim, m): run(out, sim, args, queries) for m, args in maps.items() for sim in ("pymunk", "vizdoom")}
    fit = run(out, "vizdoom", ["--map", "fit", "--profile", "vizdoom-quick"], queries)
    same = np.array_equal(fit["est"], res[("vizdoom", "vizdoom map")]["est"])
    print(f"--map fit --profile vizdoom-quick gives the map file's estimates: {same}")
    print()
    print("| frames | map | recall 25 / 50 / 100 cm | 50 cm + 10 deg | median error | query ms median |")
    print("|---|---|---|---|---|---|")
    for (sim, m), r in res.items():
        s = r["summary"]
        print(f"| {sim} | {m} | {100 * s['recall_25cm']:.0f} / {100 * s['recall_50cm']:.0f} / "
              f"{100 * s['recall_100cm']:.0f} % | {100 * s['recall_50cm_10deg']:.0f} % | "
              f"{100 * s['median_loc_err_m']:.1f} cm, {s['median_heading_err_deg']:.2f} deg | "
              f"{s['query_ms_median']:.0f} |")
    print()
    rng = np.random.default_rng(0)
    for m in maps:
        paired(res[("pymunk", m)], res[("vizdoom", m)], f"vizdoom − pymunk frames, {m}", rng)
    for sim in ("pymunk", "vizdoom"):
        paired(res[(sim, "pymunk map")], res[(sim, "vizdoom map")], f"vizdoom − pymunk map, {sim} frames", rng)
    paired(res[("pymunk", "pymunk map")], res[("vizdoom", "vizdoom map")],
           "each backend on its own map (vizdoom − pymunk)", rng)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3], *(int(a) for a in sys.argv[4:5]))
