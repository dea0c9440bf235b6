"""Measure the ViZDoom backend (issue 37 §2): pose quantisation, frames after a warp, the camera
projection, the depth buffer, frames per second. Prints the figures docs/notebook/vizdoom.md
records; ``python docs/data/vizdoom/doom_calibrate.py [quant|settle|projection|projection_scan|depth|fps ...]``.
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

from navbench.geometry import Intrinsics  # noqa: E402
from navbench.level import Level, Obstacle, Wall  # noqa: E402
from navbench.levelio import load_level  # noqa: E402
from navbench.sim.camera import RaycastCamera  # noqa: E402
from navbench.sim.doom.engine import DoomEngine  # noqa: E402
from navbench.sim.world import sample_free_points  # noqa: E402

sys.path.insert(0, str(ROOT / "tests" / "sim"))
from fixtures import TEXTURES  # noqa: E402


def hall() -> Level:
    """A 40 m x 20 m hall with a wall at x = 30 m (face at 29.9 m) and two boxes at
    x in [10, 10.5] m: A (y in [9, 11] m, 0.8 m high: above the eye) and B (y in [14, 16] m,
    0.2 m high: below it)."""
    return Level("hall", 40.0, 20.0, (Wall((30.0, 0.0), (30.0, 20.0), 0.2, 0),),
                 (Obstacle(((10.0, 9.0), (10.5, 9.0), (10.5, 11.0), (10.0, 11.0)), 0.8, 1),
                  Obstacle(((10.0, 14.0), (10.5, 14.0), (10.5, 16.0), (10.0, 16.0)), 0.2, 3)),
                 TEXTURES, 1, 2)


def quant(res=(320, 240)):
    lv = hall()
    e = DoomEngine(lv, res)
    rng = np.random.default_rng(0)
    pe, ae = [], []
    for _ in range(500):
        p = np.array([rng.uniform(1, 9), rng.uniform(1, 19), rng.uniform(-math.pi, math.pi)])
        q = e.set_pose(p)
        pe.append(q[:2] - p[:2])
        ae.append((q[2] - p[2] + math.pi) % (2 * math.pi) - math.pi)
    pe, ae = np.abs(np.array(pe)), np.abs(np.degrees(ae))
    print(f"position |engine - asked| max {pe.max() * 100:.4f} cm (nearest cm: 0.5), mean {pe.mean() * 100:.3f} cm")
    print(f"heading |engine - asked| max {ae.max():.6f} deg; engine unit 360/65536 = {360 / 65536:.6f} deg, "
          f"half {180 / 65536:.6f}")
    g = e.game
    g.send_game_command("warp 500.99 300.7")
    g.advance_action(1, True)
    print("'warp 500.99 300.7' ->", g.get_state().game_variables[:2], "(atoi: truncation)")
    for d in (20.0, 0.5, 0.004):
        a0 = g.get_state().game_variables[2]
        g.set_action([d])
        g.advance_action(1, True)
        a1 = g.get_state().game_variables[2]
        print(f"TURN_LEFT_RIGHT_DELTA {d}: angle {a0:.6f} -> {a1:.6f} deg "
              f"(turned {(a0 - a1 + 180) % 360 - 180:.6f}, in 1/65536 turns {((a0 - a1 + 180) % 360 - 180) * 65536 / 360:.3f})")
    g.set_action([0.0])
    e.close()


def settle(res=(320, 240)):
    lv = load_level(ROOT / "levels" / "house-1.json")
    rng = np.random.default_rng(1)
    pts = sample_free_points(lv, rng, 60, 0.3)
    e = DoomEngine(lv, res, settle_tics=1)
    g = e.game
    diff1 = diff2 = 0
    camz = []
    for k in range(len(pts) - 1):
        pose = (*pts[k], rng.uniform(-math.pi, math.pi))
        e.set_pose(pose)  # one tic: the warp's
        camz.append(e.variables()[3])
        rgb1 = e.buffers()[0].copy()
        g.advance_action(1, True)
        e._state = g.get_state()
        rgb2, camz2 = e.buffers()[0].copy(), e.variables()[3]
        g.advance_action(1, True)
        e._state = g.get_state()
        rgb3 = e.buffers()[0].copy()
        diff1 += int(not np.array_equal(rgb1, rgb2))
        diff2 += int(not np.array_equal(rgb2, rgb3))
    print(f"camera z in the warp's tic: {sorted(set(camz))} units; one tic later {camz2}")
    print(f"frames differing: warp tic vs +1 tic {diff1}/{len(pts) - 1}, +1 vs +2 tics {diff2}/{len(pts) - 1}")
    e.close()
    # the backend's path (settle_tics=2: the warp's tic without a state update) against 3 tics
    a, b = DoomEngine(lv, res, settle_tics=2), DoomEngine(lv, res, settle_tics=3)
    same = 0
    for p in pts:
        pose = (*p, rng.uniform(-math.pi, math.pi))
        a.set_pose(pose)
        b.set_pose(pose)
        same += int(all(np.array_equal(x, y) for x, y in zip(a.buffers(), b.buffers())) and a.variables()[3] == 50)
    print(f"set_pose with settle_tics 2 vs 3: identical frames (rgb and depth, eye at 50) {same}/{len(pts)}")
    a.close()
    b.close()


def _edges(mask_1d):
    idx = np.flatnonzero(mask_1d)
    return (idx[0], idx[-1]) if idx.size else None


def projection(res=(320, 240)):
    """Least squares of the silhouette edges of boxes A and B (depth buffer: box vs saturated
    far wall) against their corners' projections."""
    lv = hall()
    e = DoomEngine(lv, res)
    W, H = res
    ch = 50.0
    cols, Xs, rows, Ys = [], [], [], []
    corners = {"A": np.array([[1000, 900], [1050, 900], [1050, 1100], [1000, 1100]], float),
               "B": np.array([[1000, 1400], [1050, 1400], [1050, 1600], [1000, 1600]], float)}
    for box, yc in (("A", 1000.0), ("B", 1500.0)):
        for z in np.arange(150, 700, 9.7):
            for dy in np.arange(-60, 61, 7.3):
                px, py = 1000 - z, yc + dy
                q = e.set_pose((px / 100, py / 100, 0.0)) * 100
                depth = e.buffers()[1]
                near = depth < 255 * H // 480  # the far wall is saturated (and far flats above it)
                c = corners[box] - q[:2]
                X = -c[:, 1] / c[:, 0]  # camera x / z of the corners (facing +x)
                mid_row = H // 2 + (H // 8 if box == "B" else -H // 40)
                ed = _edges(near[mid_row])
                if ed is None or ed[0] == 0 or ed[1] == W - 1:
                    continue
                cols += [ed[0] - 0.5, ed[1] + 0.5]
                Xs += [X.min(), X.max()]
                colv = near[:, W // 2]
                # the box's top edge against the saturated far wall: scanning up from the middle
                # row (A: its face's top, above the eye) or from the bottom row (B: the far edge
                # of its top, below the eye) to the first far pixel
                j = H // 2 if box == "A" else H - 1
                if not colv[j]:
                    continue
                while j > 0 and colv[j - 1]:
                    j -= 1
                if j == 0:
                    continue
                rows.append(j - 0.5)
                Ys.append(-(80 - ch) / c[0, 0] if box == "A" else (ch - 20) / c[1, 0])
    A = np.stack([np.ones(len(Xs)), Xs], 1)
    (cx, fx), r1, *_ = np.linalg.lstsq(A, np.array(cols), rcond=None)
    B = np.stack([np.ones(len(Ys)), Ys], 1)
    (cy, fy), r2, *_ = np.linalg.lstsq(B, np.array(rows), rcond=None)
    rx = np.array(cols) - A @ [cx, fx]
    ry = np.array(rows) - B @ [cy, fy]
    for name, X, r in (("x", np.array(Xs), rx), ("y", np.array(Ys), ry)):
        bins = np.quantile(X, np.linspace(0, 1, 6))
        which = np.clip(np.searchsorted(bins, X) - 1, 0, 4)
        print(f"  residual {name} by fifths of X/Z: " + ", ".join(f"{r[which == b].mean():+.2f}" for b in range(5)))
    print(f"{W}x{H}: fx {fx:.3f} cx {cx:.3f} (n {len(Xs)}, |resid| max {np.abs(rx).max():.2f} px); "
          f"fy {fy:.3f} cy {cy:.3f} (n {len(Ys)}, |resid| max {np.abs(ry).max():.2f} px); fy/fx {fy / fx:.4f}")
    e.close()
    return Intrinsics(W, H, fx, fy, cx, cy)


def projection_scan(res=(320, 240), n_poses=12):
    """The projection that puts most converted depth-buffer pixels within one step of the exact
    z-depth (house-1): fx in {0.99, 1, 1.01} W / 2, fy from 1.14 to 1.20 fx, c = (W / 2 - 0.5,
    H / 2 - 0.5); the six best are printed (fraction, fx, fy, cy, step, offset)."""
    from navbench.sim.doom.engine import saturation_value

    W, H = res
    lv = load_level(ROOT / "levels" / "house-1.json")
    rng = np.random.default_rng(5)
    pts = sample_free_points(lv, rng, n_poses, 0.3)
    e = DoomEngine(lv, res)
    frames = [(e.set_pose((*p, rng.uniform(-math.pi, math.pi))), e.buffers()[1].astype(float)) for p in pts]
    e.close()
    sat = saturation_value(H)
    best = []
    for fy in np.arange(1.14, 1.205, 0.005) * W / 2:
        for fx in np.array([0.99, 1.0, 1.01]) * W / 2:
            cam = RaycastCamera(lv, Intrinsics(W, H, fx, fy, W / 2 - 0.5, H / 2 - 0.5), 0.5)
            zs, vs = [], []
            for q, d in frames:
                f = cam.render(q)
                ok = f.valid & (d < sat)
                zs.append(f.depth[ok] * 100)
                vs.append(d[ok])
            z, v = np.concatenate(zs), np.concatenate(vs)
            a, b = np.polyfit(v, z, 1)
            best.append((float(np.mean(np.abs(a * v + b - z) <= a)), fx, fy, H / 2 - 0.5, a, b))
    best.sort(reverse=True)
    for r in best[:6]:
        print(f"  within one step {r[0]:.4%}: fx {r[1]:.2f} fy {r[2]:.2f} cy {r[3]} (z = {r[4]:.4f} v + {r[5]:.3f})")


def depth(res=(320, 240), intr: Intrinsics | None = None, n_poses=40):
    """The raw depth buffer against the exact z-depth of the converted level (house-1): the
    linear map z = a v + b (least squares on pixels below saturation), its step a, and how
    many pixels the converted value (navbench.sim.doom.engine.depth_to_metres) puts within
    one step of the exact depth, by surface (floor, ceiling, sides)."""
    from navbench.geometry import pixel_rays
    from navbench.sim.doom.engine import DOOM_INTRINSICS, saturation_value
    from navbench.sim.doom.simulator import EDGE_STEPS, buffer_to_metres

    intr = intr or DOOM_INTRINSICS[res]
    lv = load_level(ROOT / "levels" / "house-1.json")
    rng = np.random.default_rng(2)
    pts = sample_free_points(lv, rng, n_poses, 0.3)
    e = DoomEngine(lv, res)
    cam = RaycastCamera(lv, intr, 0.5)
    rays = pixel_rays(intr)
    sat = saturation_value(res[1])
    zs, vs, ks, es = [], [], [], []
    for p in pts:
        q = e.set_pose((*p, rng.uniform(-math.pi, math.pi)))
        f = cam.render(q)
        d = e.buffers()[1]
        wz = 0.5 - rays[..., 1] * f.depth
        kind = np.where(np.abs(wz) < 1e-4, 0, np.where(np.abs(wz - lv.height) < 1e-4, 1, 2))
        ok = f.valid
        zs.append(f.depth[ok] * 100)
        vs.append(d[ok].astype(float))
        ks.append(kind[ok])
        es.append(buffer_to_metres(d, res, EDGE_STEPS)[1][ok] | (d[ok] >= sat))
    z, v, kind, kept = np.concatenate(zs), np.concatenate(vs), np.concatenate(ks), np.concatenate(es)
    below = v < sat
    far = np.percentile(z[~below], 1) if (~below).any() else float("nan")
    print(f"{res[0]}x{res[1]} {intr}: saturation value {sat}; pixels at or above it {np.mean(~below):.3%}, "
          f"their exact z >= {far:.0f} units (1st pct); below it, exact z <= "
          f"{np.percentile(z[below], 99.9):.0f} (99.9th pct)")
    a, b = np.polyfit(v[below], z[below], 1)
    print(f"  z = {a:.4f} v + {b:.3f} units  (one step {a:.3f} units = {a / 100:.4f} m)")
    for k, name in enumerate(("floor", "ceiling", "sides")):
        m = below & (kind == k)
        r = (a * v[m] + b) - z[m]
        print(f"  {name}: n {m.sum()}, |conv - exact| <= one step {np.mean(np.abs(r) <= a):.4%}, "
              f"<= half a step {np.mean(np.abs(r) <= a / 2):.3%}, p1 {np.percentile(r, 1):+.2f}, "
              f"p99 {np.percentile(r, 99):+.2f} units")
    r = (a * v[below] + b) - z[below]
    k = kept[below]
    print(f"  all surfaces: within one step {np.mean(np.abs(r) <= a):.4%}; off the discontinuities "
          f"(edge_steps {EDGE_STEPS}, keeping {np.mean(k):.3%} of them) {np.mean(np.abs(r[k]) <= a):.4%}")
    e.close()


def fps(res=(320, 240), repeats=7, steps=200):
    """Frames per second: ``reset(pose)`` (teleport, settle, frame converted to a navbench
    Frame) of DoomSimulator over ``steps`` free poses of house-1, median of ``repeats``; the
    pymunk Simulator's ray-cast camera on the same poses beside it."""
    from navbench.geometry import PAPER_CAMERA
    from navbench.sim.doom.simulator import DoomSimulator
    from navbench.sim.world import Simulator

    lv = load_level(ROOT / "levels" / "house-1.json")
    rng = np.random.default_rng(3)
    pts = sample_free_points(lv, rng, steps, 0.3)
    poses = [(*p, rng.uniform(-math.pi, math.pi)) for p in pts]
    intr = PAPER_CAMERA.scaled(res[0] / 320)
    for name, sim in (("doom", DoomSimulator(lv, intrinsics=intr)), ("pymunk", Simulator(lv, intrinsics=intr))):
        sim.reset(poses[0])  # compile / warm up
        rates = []
        for _ in range(repeats):
            t = time.perf_counter()
            for p in poses:
                sim.reset(p)
            rates.append(steps / (time.perf_counter() - t))
        print(f"{res[0]}x{res[1]} {name}: reset(pose) with frame, median of {repeats} x {steps}: "
              f"{statistics.median(rates):.0f} frames/s (min {min(rates):.0f}, max {max(rates):.0f})")
        if name == "doom":
            sim.close()


if __name__ == "__main__":
    what = sys.argv[1:] or ["quant", "settle", "projection", "projection_scan", "depth", "fps"]
    for res in ((320, 240), (160, 120)):
        for w in what:
            print(f"== {w} {res}")
            globals()[w](res)
