"""The issue-13 map figures: your own views through the CLI alone vs the Python API, and the fit
time of imported views.

Usage (from the repository root, with the venv's python and PYTHONPATH=.):

    python docs/data/own-data/own_views_figures.py same   [--level house-1] [--frames 300] [--camera paper]
                                                [--profile quick] [--steps N] [--device cpu]
    python docs/data/own-data/own_views_figures.py timing [--level house-1] [--frames 2000] [--camera half]
                                                [--profile quick] [--steps N] [--repeats 3] [--device cpu]
    python docs/data/own-data/own_views_figures.py ratio  [--frames 2000] [--camera half] [--steps 100] [--repeats 3]

Both work in a fresh scratch project (``--work DIR``, default a temporary directory, with
``levels/`` linked to this repository's) and print one JSON object.

``same``: the CLI alone (``collect-views LEVEL --count F --camera C``, ``export-views KEY DIR``,
``import-views DIR --store``, ``fit-map --views KEY``) against the Python API on the same data
(:func:`navbench.worldmodel.tum.import_views` of that directory and
:func:`navbench.worldmodel.fitviews.fit_views` with the profile's fit settings and the default
split, every 10th view held out). Prints both qualities and their largest difference (the
issue asks for <= 1e-6), and, for information, the same fit on the views before the export
(whose depth has not been quantised to 1/5000 m).

``timing``: ``--frames`` views collected, exported and imported through the CLI, then
``fit-map --views KEY --force`` ``--repeats`` times with the profile's fit settings; prints
the import wall time, every ``fit_seconds`` (the fit's own timer) and their median, and the
load average before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from scripts._env import pythonpath_first  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]


def nb(work: Path, *args: str) -> str:
    """Run ``navbench ARGS`` in ``work`` as its own process; its stdout (stderr on failure)."""
    env = {**os.environ, "PYTHONPATH": pythonpath_first(ROOT), "NUMBA_CACHE_DIR": str(ROOT / ".numba_cache")}
    p = subprocess.run([sys.executable, "-m", "navbench.cli.main", *map(str, args)], cwd=work,
                       capture_output=True, text=True, env=env)
    if p.returncode != 0:
        raise SystemExit(f"navbench {' '.join(map(str, args))} failed:\n{p.stderr}")
    return p.stdout


def json_of(out: str) -> dict:
    return json.loads(out[out.index("{"):])


def cli_views(work: Path, a) -> tuple[str, Path, float]:
    """collect-views -> export-views -> import-views --store: ``(views key, TUM dir, import s)``."""
    out = nb(work, "collect-views", a.level, "--count", a.frames, "--camera", a.camera,
             "--profile", a.profile)
    key = out.split("key ")[1].split()[0]
    tum = work / "tum"
    nb(work, "export-views", key, tum)
    t0 = time.perf_counter()
    imp = json_of(nb(work, "import-views", tum, "--store", "--json"))
    return imp["key"], tum, time.perf_counter() - t0


def fit_args(a) -> list[str]:
    out = ["--profile", a.profile, "--device", a.device, "--json"]
    return out + (["--steps", str(a.steps)] if a.steps else [])


def same(work: Path, a) -> dict:
    import numpy as np

    from navbench.pipeline.profiles import load_profile
    from navbench.pipeline.stages.imported import FitViewsConfig
    from navbench.worldmodel.fitviews import fit_views
    from navbench.worldmodel.tum import import_views
    from navbench.worldmodel.views import load_views

    key, tum, _ = cli_views(work, a)
    cli = json_of(nb(work, "fit-map", "--views", key, *fit_args(a)))
    prof = load_profile(a.profile)
    cfg = FitViewsConfig(a.steps or prof.fit_steps, prof.fit_seed, {**prof.fit, "device": a.device})
    _, api = fit_views(import_views(tum), cfg.fit_config())
    orig_dir = next((work / "results" / "cache" / "collect-views").iterdir()) / "views"
    _, direct = fit_views(load_views(orig_dir), cfg.fit_config())
    keys = ("depth_mae_m", "rgb_l1", "coverage")
    return {"figure": "same", "level": a.level, "frames": int(a.frames), "camera": a.camera,
            "steps": cfg.steps, "device": a.device,
            "cli": {k: cli[k] for k in keys}, "api": {k: api[k] for k in keys},
            "max_abs_diff_cli_api": max(abs(cli[k] - api[k]) for k in keys),
            "before_export": {k: direct[k] for k in keys},
            "max_abs_diff_before_export": float(np.max([abs(direct[k] - api[k]) for k in keys])),
            "fit_seconds_cli": cli["fit_seconds"]}


def timing(work: Path, a) -> dict:
    load0 = os.getloadavg()
    key, _, import_s = cli_views(work, a)
    runs = []
    for _ in range(a.repeats):
        r = json_of(nb(work, "fit-map", "--views", key, "--force", *fit_args(a)))
        runs.append(r["fit_seconds"])
    return {"figure": "timing", "level": a.level, "frames": int(a.frames), "camera": a.camera,
            "steps": r["steps"], "device": r["device"], "import_seconds": import_s,
            "fit_seconds": runs, "fit_seconds_median": statistics.median(runs),
            "loadavg_before": load0, "loadavg_after": os.getloadavg()}


def ratio(work: Path, a) -> dict:
    """ms per fit step on the collected views vs the same views exported and imported
    (interleaved repeats): whether imported views cost the fit anything."""
    from navbench.geometry import camera_by_name
    from navbench.levelio import resolve_level
    from navbench.worldmodel.fit import FitConfig, fit_map
    from navbench.worldmodel.tum import export_views, import_views
    from navbench.worldmodel.views import collect_views, load_views, save_views

    v = collect_views(resolve_level(str(ROOT / "levels" / f"{a.level}.json")), a.frames,
                      camera_by_name(a.camera), seed=0)
    imp = load_views(save_views(import_views(export_views(v, work / "tum")), work / "imported"))
    cfg = FitConfig(steps=a.steps or 100, device=a.device)
    ms = {"collected": [], "imported": []}
    for _ in range(a.repeats):
        for name, views in (("collected", v), ("imported", imp)):
            ms[name].append(fit_map(views, cfg)[1]["ms_per_step"])
    med = {k: statistics.median(x) for k, x in ms.items()}
    return {"figure": "ratio", "frames": a.frames, "camera": a.camera, "steps": cfg.steps,
            "ms_per_step": ms, "median": med, "imported_over_collected": med["imported"] / med["collected"],
            "loadavg": os.getloadavg()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("figure", choices=("same", "timing", "ratio"))
    ap.add_argument("--level", default="house-1")
    ap.add_argument("--frames", type=int, default=None)
    ap.add_argument("--camera", default=None)
    ap.add_argument("--profile", default="quick")
    ap.add_argument("--steps", type=int, default=None, help="fit steps (default: the profile's)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--work", type=Path, default=None)
    a = ap.parse_args()
    a.frames = a.frames or (300 if a.figure == "same" else 2000)
    a.camera = a.camera or ("paper" if a.figure == "same" else "half")
    with tempfile.TemporaryDirectory() as tmp:
        work = a.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        if not (work / "levels").exists():
            (work / "levels").symlink_to(ROOT / "levels")
        print(json.dumps({"same": same, "timing": timing, "ratio": ratio}[a.figure](work, a), indent=1))


if __name__ == "__main__":
    main()
