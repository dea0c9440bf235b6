"""Measure world-model fit quality on a level: pure eq. 3 vs eq. 3 + the free-space term.

Usage: .venv/bin/python docs/data/choices/fit_quality.py LEVEL [--views 5000] [--heldout 200]
       [--camera half] [--steps 10000] [--variants aux,pure] [--cache DIR] [--out FILE.json]
       [--save-maps DIR] [--device cpu|auto|cuda|torch-cpu]

Collects (or reuses from --cache) the training views (seed 1) and held-out views (seed 2, never
used for fitting), fits each variant with FitConfig defaults except the named changes, and
prints one JSON line per variant: depth MAE (m), RGB L1, coverage, slice precision/recall,
fit time (wall and CPU seconds). ``--device`` sets FitConfig.device for every variant (``cpu``:
the sparse numba path; ``cuda``: the device path on the GPU; ``torch-cpu``: the device path's
arithmetic on the CPU, slow); the variant ``torch`` is the defaults on ``torch-cpu``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

VARIANTS = {
    "aux": {},  # the defaults: box init + free-space term
    "pure": {"free_space_weight": 0.0},  # eq. 3 alone (box init)
    "pure-empty": {"free_space_weight": 0.0, "init": "empty"},
    "aux-empty": {"init": "empty"},
    "aux2": {"free_space_samples": 2},
    "aux1": {"free_space_samples": 1},
    "adam": {"optimizer": "adam"},
    "pure-adam": {"free_space_weight": 0.0, "optimizer": "adam"},
    "torch": {"device": "torch-cpu"},  # the GPU path's code and semantics, run on the CPU
}


def main() -> None:
    from navbench.geometry import camera_by_name
    from navbench.levelio import resolve_level
    from navbench.worldmodel.fit import FitConfig, fit_map
    from navbench.worldmodel.views import collect_views, load_views, save_views

    ap = argparse.ArgumentParser()
    ap.add_argument("level")
    ap.add_argument("--views", type=int, default=5000)
    ap.add_argument("--heldout", type=int, default=200)
    ap.add_argument("--camera", default="half")
    ap.add_argument("--steps", type=int, default=10_000)
    ap.add_argument("--variants", default="aux,pure")
    ap.add_argument("--cache", default=None)
    ap.add_argument("--out", default=None)
    ap.add_argument("--save-maps", default=None, help="directory to save each variant's map.npz")
    ap.add_argument("--device", default=None, help="FitConfig.device for every variant")
    args = ap.parse_args()
    level = resolve_level(args.level)
    intr = camera_by_name(args.camera)

    def views(count, seed, name):
        if args.cache:
            p = Path(args.cache) / f"{level.name}-{args.camera}-{count}-{seed}"
            if (p / "views.json").is_file():
                return load_views(p)
            v = collect_views(level, count, intr, seed)
            save_views(v, p)
            return load_views(p)
        return collect_views(level, count, intr, seed)

    train = views(args.views, 1, "train")
    held = views(args.heldout, 2, "heldout")
    results = []
    for name in args.variants.split(","):
        kw = dict(VARIANTS[name])
        if args.device:
            kw["device"] = args.device
        cfg = FitConfig(steps=args.steps, **kw)
        c0, w0 = time.process_time(), time.perf_counter()
        vmap, m = fit_map(train, cfg, heldout=held, level=level)
        if args.save_maps:
            from navbench.worldmodel.grid import save_map

            save_map(vmap, Path(args.save_maps) / f"{level.name}-{name}.npz")
        m.update(variant=name, device=m.get("device", "cpu"), level=level.name, views=args.views, camera=args.camera,
                 wall_s=time.perf_counter() - w0, cpu_s=time.process_time() - c0)
        m.pop("loss_curve", None)
        print(json.dumps(m), flush=True)
        results.append(m)
    if args.out:
        Path(args.out).write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
