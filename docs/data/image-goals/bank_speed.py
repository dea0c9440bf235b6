"""The localiser bank's build time: the compiled pass against the reference loop, in alternation.

    PYTHONPATH=. .venv/bin/python docs/data/image-goals/bank_speed.py house-1,house-2 --map fit \
        --profile examples/paper-half.toml --repeats 3

Per level, builds the default :class:`~navbench.localize.LocalizerConfig`'s panoramas on the
level's map (``--map true|fit|KEY`` as ``localize-eval``) ``--repeats`` times with the reference
loop (:func:`navbench.localize.signature.panorama` per lattice point) and with the compiled pass
(:func:`navbench.localize.bankrender.panoramas`, what ``build_bank`` runs), alternating which goes
first; checks that both give the same bits and prints per level the lattice size, the median
wall and process-CPU seconds of each and the reference / compiled ratio of the CPU medians.
``--threads 1`` (the default) is what a pool worker runs (the unknown-house loop builds its
banks there). Writes nothing but the cache it needs. Under load compare the ratio only.
"""

from __future__ import annotations

import argparse
import os
import sys
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("levels", help="comma-separated level names")
    ap.add_argument("--map", default="fit")
    ap.add_argument("--profile", default=None)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1, help="numba threads (a pool worker runs 1)")
    args = ap.parse_args()
    if args.repeats < 1 or args.threads < 1:
        ap.error("--repeats and --threads must be >= 1")

    import numba
    import numpy as np

    from navbench.errors import NavbenchError
    from navbench.geometry import CAMERA_HEIGHT
    from navbench.localize import LocalizerConfig
    from navbench.localize import signature as sig
    from navbench.localize.bankrender import panoramas
    from navbench.pipeline.profiles import load_profile
    from navbench.pipeline.run import stage_context
    from navbench.pipeline.stages import study_level, study_map

    numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
    cfg = LocalizerConfig()
    ycs = sig.elevations(cfg.rows, cfg.row_top, cfg.row_step)
    quad = sig.quadrant_intrinsics(cfg.bins, cfg.rows, cfg.row_top, cfg.row_step)
    try:
        prof = load_profile(args.profile) if args.map == "fit" else None
        ctx = stage_context()
        maps = []
        for name in args.levels.split(","):
            level_ref = study_level(ctx, name, prof)
            maps.append((name, study_map(ctx, args.map, level_ref, prof).load()))
    except NavbenchError as e:
        sys.exit(f"error: {e}")

    def reference(render, points):
        out = np.empty((len(points), 2 * cfg.rows, cfg.bins), np.float32)
        for i, xy in enumerate(points):
            out[i] = sig.panorama(render.render, xy, cfg.bins, ycs, cfg.grey_weight, quad,
                                  cfg.depth_feature, cfg.feature_range)
        return out

    def compiled(render, points):
        return panoramas(render, points, cfg.bins, ycs, cfg.grey_weight, quad, cfg.depth_feature,
                         cfg.feature_range)

    print(f"numba threads {numba.get_num_threads()}, load average {os.getloadavg()[0]:.1f}, "
          f"{args.repeats} repeats each")
    print(f"{'level':10s} {'points':>7s} {'reference wall / CPU s':>24s} {'compiled wall / CPU s':>23s} "
          f"{'ratio':>6s} same")
    for name, vmap in maps:
        occ, xs, ys = vmap.occupancy_slice("band")
        points = sig.lattice_points(occ, xs, ys, cfg.lattice_step, cfg.clearance)
        render = vmap.renderer(quad, CAMERA_HEIGHT)
        compiled(render, points[:2])  # compile outside the timing
        times = {"reference": ([], []), "compiled": ([], [])}
        outs = {}
        for r in range(args.repeats):
            for which in (("reference", "compiled") if r % 2 == 0 else ("compiled", "reference")):
                w0, c0 = time.perf_counter(), time.process_time()
                outs[which] = (reference if which == "reference" else compiled)(render, points)
                times[which][0].append(time.perf_counter() - w0)
                times[which][1].append(time.process_time() - c0)
        same = np.array_equal(outs["reference"].view(np.uint32), outs["compiled"].view(np.uint32))
        med = {k: (float(np.median(w)), float(np.median(c))) for k, (w, c) in times.items()}
        print(f"{name:10s} {len(points):7d} {med['reference'][0]:11.2f} / {med['reference'][1]:6.2f}"
              f"{med['compiled'][0]:14.2f} / {med['compiled'][1]:6.2f} "
              f"{med['reference'][1] / med['compiled'][1]:6.2f} {same}")


if __name__ == "__main__":
    main()
