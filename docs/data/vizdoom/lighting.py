"""Issue 37: Doom's distance lighting in the converted maps, measured.

``python docs/data/vizdoom/lighting.py > docs/data/vizdoom/lighting.txt`` (~1 min):

1. *patch*: the mean colour of one 0.5 m x 0.5 m wall patch (STARTAN2, the centre of a long
   wall, at eye height) seen straight on from 0.5 to 8 m, and from 3 m at 0, 30 and 60 deg off
   its normal; and of a 0.5 m x 0.5 m floor patch half-way to the wall. Each figure is the mean
   over 16 poses jittered by up to +-5 cm (the engine samples textures at one texel per pixel,
   without filtering: one pose's patch mean moves with the sub-texel phase; the spread over the
   jitter is printed). 320 x 240. Per sector light level (and with the ``r_visibility 0``
   console setting, which turns ZDoom's distance fade off).
2. *house-1*: 40 random poses of house-1 rendered at sector light 192 and 255; the intensity
   ratio of the same pixel (192 / 255) per depth bin (the depth buffer's z).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "sim"))

from fixtures import single_wall  # noqa: E402

from navbench.levelio import load_level  # noqa: E402
from navbench.sim.doom.engine import DOOM_INTRINSICS, DoomEngine  # noqa: E402
from navbench.sim.doom.simulator import buffer_to_metres  # noqa: E402
from navbench.sim.world import sample_free_points  # noqa: E402

RES = (320, 240)
K = DOOM_INTRINSICS[RES]
XF = 8.95  # the wall's face (single_wall(9.0, 0.1))
I, J = np.meshgrid(np.arange(RES[0]), np.arange(RES[1]))


def _rays(pose):
    x, y, th = pose
    r = (I - K.cx) / K.fx
    return x, y, math.cos(th) + r * math.sin(th), math.sin(th) - r * math.cos(th)


def wall_mask(pose, half=0.25):
    """Pixels whose ray meets the wall face within ``half`` m of (y 5 m, height 0.5 m)."""
    x, y, dx, dy = _rays(pose)
    with np.errstate(divide="ignore"):
        t = (XF - x) / dx
    return (t > 0) & (np.abs(y + t * dy - 5.0) <= half) & (np.abs(t * (J - K.cy) / K.fy) <= half)


def floor_mask(pose, centre, half=0.25):
    """Pixels whose ray meets the floor within ``half`` m of ``centre`` (x, y)."""
    x, y, dx, dy = _rays(pose)
    s = (J - K.cy) / K.fy
    with np.errstate(divide="ignore"):
        t = np.where(s > 0, 0.5 / s, np.inf)
    return np.isfinite(t) & (np.abs(x + t * dx - centre[0]) <= half) & (np.abs(y + t * dy - centre[1]) <= half)


def patch(light: int, args: str = "") -> None:
    lv = single_wall(9.0, 0.1)
    jit = np.random.default_rng(0).uniform(-0.05, 0.05, (16, 2))
    print(f"sector light {light}{' ' + args if args else ''}")
    with DoomEngine(lv, RES, light_level=light, game_args=args) as e:
        base = None
        for d in (0.5, 1, 2, 3, 4, 6, 8):
            ws, fs = [], []
            for jx, jy in jit:
                q = e.set_pose((XF - d + jx, 5.0 + jy, 0.0))
                rgb = e.buffers()[0].astype(float)
                ws.append(rgb[wall_mask(q)].mean(0))
                m = floor_mask(q, (XF - d / 2, 5.0))
                if m.any():
                    fs.append(rgb[m].mean(0))
            ws = np.array(ws)
            base = ws.mean() if base is None else base
            floor = f"floor patch at {d / 2:.2f} m: {np.round(np.mean(fs, 0), 1)}" if fs else ""
            print(f"  wall {d:3.1f} m: RGB {np.round(ws.mean(0), 1)} (jitter sd {np.round(ws.std(0), 1)}), "
                  f"brightness / 0.5 m's {ws.mean() / base:.3f}   {floor}")
        for ang in (0, 30, 60):
            a, d = math.radians(ang), 3.0
            ws = []
            for jx, jy in jit:
                x, y = XF - d * math.cos(a) + jx, 5.0 + d * math.sin(a) + jy
                q = e.set_pose((x, y, math.atan2(5.0 - y, XF - x)))
                ws.append(e.buffers()[0].astype(float)[wall_mask(q)].mean(0))
            print(f"  wall 3 m at {ang:2d} deg off the normal: RGB {np.round(np.mean(ws, 0), 1)}")


def house(n: int = 40) -> None:
    lv = load_level(ROOT / "levels" / "house-1.json")
    rng = np.random.default_rng(0)
    poses = [(*p, rng.uniform(-math.pi, math.pi)) for p in sample_free_points(lv, rng, n, 0.3)]
    out = {}
    for light in (192, 255):
        with DoomEngine(lv, RES, light_level=light) as e:
            fr = []
            for p in poses:
                e.set_pose(p)
                rgb, buf = e.buffers()
                fr.append((rgb.astype(float).sum(-1).ravel(), buf.copy()))
        out[light] = fr
    z = np.concatenate([buffer_to_metres(b, RES, None)[0].ravel() for _, b in out[255]])
    a = np.concatenate([f for f, _ in out[255]])
    b = np.concatenate([f for f, _ in out[192]])
    ok = np.isfinite(z) & (a > 30)
    print(f"house-1, {n} poses, {RES[0]} x {RES[1]}: pixel intensity at sector light 192 / at 255, by depth")
    for lo, hi in ((0, 0.5), (0.5, 1), (1, 1.5), (1.5, 2), (2, 3), (3, 4), (4, 6), (6, 9.2)):
        m = ok & (z >= lo) & (z < hi)
        print(f"  z {lo:3.1f}-{hi:3.1f} m: {m.sum():7d} px, ratio median {np.median(b[m] / a[m]):.3f} "
              f"(quartiles {np.percentile(b[m] / a[m], 25):.3f} {np.percentile(b[m] / a[m], 75):.3f})")


if __name__ == "__main__":
    for light, args in ((255, ""), (192, ""), (192, "+r_visibility 0"), (160, "")):
        patch(light, args)
    house()
