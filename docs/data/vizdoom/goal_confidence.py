"""Why the localiser's confidence check refuses the engine's goal images (image goals on the
engine, docs/notebook/vizdoom.md).

For each task of ``imagenav-quick``'s task set on LEVEL (4 per NRNS difficulty, seed 0), the
engine's goal image (the goal stage's own :class:`~navbench.pipeline.stages.goals.GoalCamera`)
is verified at its TRUE pose (the pose the engine shows) against the render of the map the goal
stage localises in (``imagenav-quick``'s fitted map on the engine's views, the same
``vizdoom-quick`` fit), exactly as :meth:`Localizer.verify_at` does it: the strided image,
the localiser's 800 verification pixels, its tolerances. Per image:

* ``conf``: the localiser's confidence at the true pose (``accept`` 0.85, the goal stage's
  ``min_confidence`` 0.8);
* where the valid pixels go: ``depth ok`` (``|dq - dp| <= inlier_abs + inlier_rel * dq``),
  of those ``colour bad`` (mean RGB difference > ``inlier_colour``), ``front`` / ``beyond``
  (the depth check fails) and ``no map`` (the map renders nothing there);
* ``conf no colour``: the confidence with the colour test dropped (depth alone);
  ``conf exact``: the same frame with the exact depth of the geometry (``depth="exact"``, the
  engine's RGB kept);
* the depth residuals in units of the buffer's step (7.12 cm at 160 x 120): query (buffer) -
  map render, exact - map render, buffer - exact (the quantisation alone);
* the depth inliers' colour test by query depth (Doom's distance lighting: brightness ratio of
  frame over map render).

Then the confidence at the true pose under alternative tolerances, and with the colours
box-filtered (the query's at full size before striding, the map render's at the strided size,
or both) before the colour test (images reaching 0.8 / 0.85, median). Diagnostic only: none
of these is a setting of navbench.

``python docs/data/vizdoom/goal_confidence.py CACHE [LEVEL [SIM]]`` (default ``tune-house``,
``vizdoom``; the map is fitted into CACHE if missing: ~3-5 min on 2 cores). With SIM
``pymunk`` the same for navbench's own goal images on ``imagenav-quick``'s pymunk map (the
"exact" depth is then the frame's own).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


def main(cache: str, level_name: str = "tune-house", sim: str = "vizdoom") -> None:
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.localize.localizer import one_sided_confidence
    from navbench.nav.imagegoal import goal_pose
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.profiles import load_profile, override
    from navbench.pipeline.stages.context import StageContext
    from navbench.pipeline.stages.goals import GoalCamera, ImageGoalConfig, _MapHandle
    from navbench.pipeline.stages.inputs import build_level_inputs
    from navbench.pipeline.stages.level import load_level_ref
    from navbench.pipeline.stages.localize import load_localizer
    from navbench.plan.tasks import load_tasks
    from navbench.sim.backends import sim_intrinsics
    from navbench.sim.camera import RaycastCamera
    from navbench.sim.doom.engine import DEPTH_LINEAR

    profile = override(load_profile("imagenav-quick"), sim=sim, levels=[level_name])
    ctx = StageContext(ArtifactStore(Path(cache)))
    inputs = build_level_inputs(ctx, profile, level_name)
    lv = load_level_ref(inputs.level)
    gcfg = ImageGoalConfig(camera=profile.camera)
    lcfg = gcfg.localizer_config()
    intr = sim_intrinsics(sim, camera_by_name(gcfg.camera))
    loc, _ = load_localizer(ctx, _MapHandle(inputs.map), intr, CAMERA_HEIGHT, lcfg, level=inputs.level)
    step = DEPTH_LINEAR[(intr.width, intr.height)][0] / 100.0  # m per buffer value (the unit on pymunk too)
    ray = RaycastCamera(lv, intr, CAMERA_HEIGHT)
    tasks = load_tasks(inputs.tasks.path)
    print(f"level {level_name}, map {inputs.map.key[:12]}, {len(tasks)} goal images, camera {gcfg.camera} "
          f"({intr.width}x{intr.height}, fx {intr.fx}), depth step {100 * step:.2f} cm; localiser inlier_abs "
          f"{lcfg.inlier_abs} m, inlier_rel {lcfg.inlier_rel}, inlier_colour {lcfg.inlier_colour}, accept "
          f"{lcfg.accept}, goal min_confidence {gcfg.min_confidence}")
    idx = loc._idx
    per = []  # per image: arrays of the verification pixels
    frames = []
    print(f"\n{'task':>4} {'d to goal':>9} {'conf':>5} {'depth ok':>8} {'col bad':>7} {'front':>5} {'beyond':>6} "
          f"{'no map':>6} {'conf no colour':>14} {'conf exact':>10} {'median |res|/step':>17}")
    with GoalCamera(sim, lv, gcfg.camera) as cam:
        for t in tasks:
            f = cam.render(t, gcfg.seed)
            shown = goal_pose(t, gcfg.seed) if cam._engine is None else cam._engine.shown
            asked = goal_pose(t, gcfg.seed)
            ex = ray.render(shown)
            small, small_ex = loc.strided(f), loc.strided(ex)
            pred = loc._renderer.render(shown)

            def flat(a, c=False):
                a = np.asarray(a)
                return a.reshape(-1, 3)[idx] if c else a.reshape(-1)[idx]

            d = {"dq": flat(small.depth).astype(np.float64), "vq": flat(small.valid),
                 "dx": flat(small_ex.depth).astype(np.float64), "vx": flat(small_ex.valid),
                 "dp": flat(pred.depth).astype(np.float64), "vp": flat(pred.valid),
                 "dc": np.abs(flat(small.rgb, True) - flat(pred.rgb, True)).mean(axis=1),
                 "lq": flat(small.rgb, True).mean(axis=1), "lp": flat(pred.rgb, True).mean(axis=1)}
            for k in (2, 3, 5):  # the query's colour box-filtered over k x k pixels before striding
                d[f"dc{k}"] = np.abs(flat(box(f.rgb, k)[::lcfg.refine_stride, ::lcfg.refine_stride], True)
                                     - flat(pred.rgb, True)).mean(axis=1)
            for k in (2, 3):  # the map render's colour box-filtered (strided pixels), and both
                d[f"dcr{k}"] = np.abs(flat(small.rgb, True) - flat(box(pred.rgb, k), True)).mean(axis=1)
                d[f"dcb{k}"] = np.abs(flat(box(small.rgb, k), True) - flat(box(pred.rgb, k), True)).mean(axis=1)
            per.append(d)
            frames.append(f)
            conf = loc.verify_at(f, shown).confidence
            r = breakdown(d, lcfg.inlier_abs, lcfg.inlier_rel, lcfg.inlier_colour)
            nocol = one_sided_confidence(d["dq"], d["vq"], d["dp"], d["vp"], np.zeros_like(d["dc"]),
                                         lcfg.inlier_abs, lcfg.inlier_rel, 1.0)[0]
            cex = one_sided_confidence(d["dx"], d["vx"], d["dp"], d["vp"], d["dc"], lcfg.inlier_abs,
                                       lcfg.inlier_rel, lcfg.inlier_colour)[0]
            both = d["vq"] & d["vp"]
            med = np.median(np.abs(d["dq"] - d["dp"])[both]) / step if both.any() else np.nan
            print(f"{t.id:4d} {float(np.hypot(*(shown[:2] - asked[:2]))) * 100:7.2f}cm {conf:5.3f} "
                  f"{r['depth_ok']:8.3f} {r['colour_bad']:7.3f} {r['front']:5.3f} {r['beyond']:6.3f} "
                  f"{r['no_map']:6.3f} {nocol:14.3f} {cex:10.3f} {med:17.2f}")
            assert abs(r["conf"] - conf) < 1e-12, (r["conf"], conf)

    cat = {k: np.concatenate([d[k] for d in per]) for k in per[0]}
    print("\nall images' verification pixels together (valid query pixels the map renders too):")
    both = cat["vq"] & cat["vp"]
    bx = cat["vq"] & cat["vx"]
    for name, res, m, dq in (("buffer - map", cat["dq"] - cat["dp"], both, cat["dq"]),
                             ("exact - map", cat["dx"] - cat["dp"], cat["vx"] & cat["vp"], cat["dx"]),
                             ("buffer - exact", cat["dq"] - cat["dx"], bx, cat["dq"])):
        a = np.abs(res[m]) / step
        tol = (lcfg.inlier_abs + lcfg.inlier_rel * dq[m]) / step
        print(f"  {name:15} n {m.sum():5d}  residual/step median {np.median(res[m]) / step:+.2f}, |.| quantiles "
              f"50/75/90/95 % {np.percentile(a, 50):.2f} {np.percentile(a, 75):.2f} {np.percentile(a, 90):.2f} "
              f"{np.percentile(a, 95):.2f}; within 0.5/1/1.5/2 steps {np.mean(a <= .5):.3f} {np.mean(a <= 1):.3f} "
              f"{np.mean(a <= 1.5):.3f} {np.mean(a <= 2):.3f}; within the localiser's tolerance {np.mean(a <= tol):.3f}")
    m = both
    tol = (lcfg.inlier_abs + lcfg.inlier_rel * cat["dq"][m]) / step
    print(f"  the localiser's depth tolerance in steps at these pixels: median {np.median(tol):.2f}, 5 % "
          f"{np.percentile(tol, 5):.2f}, min {tol.min():.2f} (query depth median {np.median(cat['dq'][m]):.2f} m)")
    near = m & (np.abs(cat["dq"] - cat["dp"]) <= lcfg.inlier_abs + lcfg.inlier_rel * cat["dq"])
    dc = cat["dc"][near]
    print(f"  colour difference of the depth inliers: median {np.median(dc):.3f}, 75/90 % {np.percentile(dc, 75):.3f} "
          f"{np.percentile(dc, 90):.3f}; above inlier_colour {lcfg.inlier_colour}: {np.mean(dc > lcfg.inlier_colour):.3f}")

    print("\ndepth inliers by query depth: share with colour bad, median brightness (mean RGB) of frame and map "
          "render, their ratio")
    for lo, hi in ((0, 1), (1, 1.5), (1.5, 2), (2, 3), (3, 4.5), (4.5, 20)):
        b = near & (cat["dq"] >= lo) & (cat["dq"] < hi)
        if b.sum() < 20:
            continue
        print(f"  {lo:4.1f}-{hi:4.1f} m  n {b.sum():5d}  colour bad {np.mean(cat['dc'][b] > lcfg.inlier_colour):.3f}  "
              f"frame {np.median(cat['lq'][b]):.3f}  map {np.median(cat['lp'][b]):.3f}  ratio "
              f"{np.median(cat['lq'][b] / np.maximum(cat['lp'][b], 1e-3)):.3f}  |diff| median {np.median(cat['dc'][b]):.3f}")

    print("\nconfidence at the true pose under other tolerances (images reaching 0.8 / 0.85, median):")
    variants = [("localiser as is", lcfg.inlier_abs, lcfg.inlier_rel, lcfg.inlier_colour, 0.0),
                ("+ half a step (abs)", lcfg.inlier_abs, lcfg.inlier_rel, lcfg.inlier_colour, 0.5),
                ("+ one step (abs)", lcfg.inlier_abs, lcfg.inlier_rel, lcfg.inlier_colour, 1.0),
                ("colour ignored", lcfg.inlier_abs, lcfg.inlier_rel, 1e9, 0.0),
                ("colour 0.15", lcfg.inlier_abs, lcfg.inlier_rel, 0.15, 0.0),
                ("colour 0.2", lcfg.inlier_abs, lcfg.inlier_rel, 0.2, 0.0),
                ("+ one step, colour 0.15", lcfg.inlier_abs, lcfg.inlier_rel, 0.15, 1.0)]
    for k in ("2", "3", "5", "r2", "r3", "b2", "b3"):
        cs = np.array([breakdown({**d, "dc": d[f"dc{k}"]}, lcfg.inlier_abs, lcfg.inlier_rel, lcfg.inlier_colour)["conf"]
                       for d in per])
        what = {"r": "map render's colour box ", "b": "both colours box "}.get(k[0], "query colour box ")
        print(f"  {what + k[-1] + 'x' + k[-1]:25} buffer: {int(np.sum(cs >= .8)):2d} / "
              f"{int(np.sum(cs >= .85)):2d} of {len(cs)}, median {np.median(cs):.3f}")
    for name, a_, r_, c_, steps in variants:
        cs = np.array([breakdown(d, a_ + steps * step, r_, c_)["conf"] for d in per])
        cx = np.array([breakdown({**d, "dq": d["dx"], "vq": d["vx"]}, a_ + steps * step, r_, c_)["conf"] for d in per])
        print(f"  {name:25} buffer: {int(np.sum(cs >= .8)):2d} / {int(np.sum(cs >= .85)):2d} of {len(cs)}, median "
              f"{np.median(cs):.3f}   exact depth: {int(np.sum(cx >= .8)):2d} / {int(np.sum(cx >= .85)):2d}, median "
              f"{np.median(cx):.3f}")
    found_pose_check(ctx, inputs, gcfg, lcfg, loc, tasks, frames, sim)


def found_pose_check(ctx, inputs, gcfg, lcfg, loc, tasks, frames, sim: str) -> None:
    """The goal stage's own result (``image-goals``, cached), and the confidence at each found
    pose under the variants: does any of them put the right places above the wrong ones?"""
    from navbench.pipeline.stages.goals import image_goals_stage, load_goals

    goals = load_goals(image_goals_stage(ctx, inputs.level, inputs.map, inputs.tasks, gcfg, sim).path)
    idx, n = loc._idx, lcfg.refine_stride
    variants = {"as is": ("dc", lcfg.inlier_colour), "colour 0.15": ("dc", 0.15), "colour 0.2": ("dc", 0.2),
                "both colours box 3x3": ("dcb3", lcfg.inlier_colour), "colour ignored": ("dc", 1e9)}
    confs = {v: [] for v in variants}
    errs = []
    for t, f in zip(tasks, frames):
        g = goals[t.id]
        if g["pose"] is None:
            continue
        small, pred = loc.strided(f), loc._renderer.render(np.asarray(g["pose"], np.float64))
        q, p = np.asarray(small.rgb).reshape(-1, 3)[idx], np.asarray(pred.rgb).reshape(-1, 3)[idx]
        d = {"dq": np.asarray(small.depth, np.float64).reshape(-1)[idx], "vq": np.asarray(small.valid).reshape(-1)[idx],
             "dp": np.asarray(pred.depth, np.float64).reshape(-1)[idx], "vp": np.asarray(pred.valid).reshape(-1)[idx],
             "dc": np.abs(q - p).mean(axis=1),
             "dcb3": np.abs(box(f.rgb, 3)[::n, ::n].reshape(-1, 3)[idx] - box(pred.rgb, 3).reshape(-1, 3)[idx]).mean(axis=1)}
        errs.append(g["error_m"])
        for v, (key, col) in variants.items():
            confs[v].append(breakdown({**d, "dc": d[key]}, lcfg.inlier_abs, lcfg.inlier_rel, col)["conf"])
    errs = np.array(errs)
    right, wrong = errs <= 0.1, errs > 0.5
    print(f"\nthe goal stage's found poses (image-goals, default localiser): {int(right.sum())} within 10 cm, "
          f"{int(wrong.sum())} more than 50 cm off (errors {', '.join(f'{e:.2f}' for e in errs[wrong])} m); "
          f"stage statuses {sorted(g['status'] for g in goals.values())}")
    print("  confidence at the found pose: right places min / median, wrong places each; separable = every "
          "right place above every wrong one")
    for v in variants:
        c = np.array(confs[v])
        sep = bool(right.any() and wrong.any() and c[right].min() > c[wrong].max())
        print(f"  {v:22} right {c[right].min():.3f} / {np.median(c[right]):.3f}   wrong "
              f"{', '.join(f'{x:.3f}' for x in c[wrong])}   separable {sep}")


def box(rgb, k: int) -> np.ndarray:
    """``rgb (H, W, 3)`` averaged over the k x k pixels from each pixel down and right (edges
    repeated): what an area-sampling camera of 1/k the resolution sees at the strided pixels."""
    rgb = np.asarray(rgb, np.float64)
    pad = np.pad(rgb, ((0, k - 1), (0, k - 1), (0, 0)), mode="edge")
    H, W = rgb.shape[:2]
    return sum(pad[i:i + H, j:j + W] for i in range(k) for j in range(k)) / (k * k)


def breakdown(d: dict, tol_abs: float, tol_rel: float, tol_colour: float) -> dict:
    """Shares of the valid query pixels of one image (as :func:`one_sided_confidence` sorts them)."""
    dq, vq, dp, vp, dc = d["dq"], d["vq"] & np.isfinite(d["dq"]), d["dp"], d["vp"], d["dc"]
    both = vq & vp & np.isfinite(dp)
    tol = tol_abs + tol_rel * np.where(vq, dq, 0.0)
    diff = np.subtract(dq, dp, out=np.zeros_like(dq), where=both)
    near = both & (np.abs(diff) <= tol)
    n = max(int(vq.sum()), 1)
    return {"conf": float((near & (dc <= tol_colour)).sum() / n), "depth_ok": float(near.sum() / n),
            "colour_bad": float((near & (dc > tol_colour)).sum() / n),
            "front": float((both & (diff < -tol)).sum() / n), "beyond": float((both & (diff > tol)).sum() / n),
            "no_map": float((vq & ~both).sum() / n)}


if __name__ == "__main__":
    main(*sys.argv[1:4])
