"""Numba kernel of :func:`navbench.worldmodel.grid.voxelize_level` (signed distance + texture)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True)
def texture_colour(t, u, v, kind, base, amp, waves, out):
    """Colour of texture ``t`` at surface coordinates ``(u, v)`` into ``out (3,)``.

    Same formula as :func:`navbench.level.surface_colour`.
    """
    twopi = 2.0 * math.pi
    if kind[t] == 0:  # waves: mean of 3 sines
        p = 0.0
        for k in range(3):
            p += math.sin(twopi * (waves[t, k, 0] * u + waves[t, k, 1] * v) + waves[t, k, 2])
        p /= 3.0
    else:  # tiles
        p = 0.7 * math.sin(twopi * waves[t, 0, 0] * u + waves[t, 0, 2]) * \
            math.sin(twopi * waves[t, 0, 1] * v + waves[t, 0, 2])
        p += 0.3 * math.sin(twopi * (waves[t, 1, 0] * u + waves[t, 1, 1] * v) + waves[t, 1, 2])
    for c in range(3):
        out[c] = min(1.0, max(0.0, base[t, c] + amp[t, c] * p))


@nb.njit(cache=True, parallel=True)
def voxelize_kernel(xs, ys, zs, width, depth, height, verts, start, pheight, ptex,
                    kind, base, amp, waves, floor_tex, ceil_tex, ramp, tau):
    nx, ny, nz = xs.shape[0], ys.shape[0], zs.shape[0]
    occ = np.zeros((nx, ny, nz), np.float32)
    col = np.zeros((nx, ny, nz, 3), np.float32)
    P = pheight.shape[0]
    for ix in nb.prange(nx):
        rgb = np.zeros(3)
        x = xs[ix]
        for iy in range(ny):
            y = ys[iy]
            for iz in range(nz):
                z = zs[iz]
                # signed distance to the union of solids, positive inside
                s = max(-z, z - height)
                s = max(s, max(max(-x, x - width), max(-y, y - depth)))
                # nearest surface: floor / ceiling first
                best = abs(z)
                btex = floor_tex
                bu = x
                bv = y
                if abs(z - height) < best:
                    best = abs(z - height)
                    btex = ceil_tex
                for p in range(P):
                    a0 = start[p]
                    a1 = start[p + 1]
                    h = pheight[p]
                    dmin = 1e30
                    inside = True
                    for e in range(a0, a1):
                        e2 = e + 1 if e + 1 < a1 else a0
                        ax, ay = verts[e, 0], verts[e, 1]
                        dx, dy = verts[e2, 0] - ax, verts[e2, 1] - ay
                        rx, ry = x - ax, y - ay
                        L2 = dx * dx + dy * dy
                        tt = (rx * dx + ry * dy) / L2
                        tt = min(1.0, max(0.0, tt))
                        qx, qy = rx - tt * dx, ry - tt * dy
                        d = math.sqrt(qx * qx + qy * qy)
                        if dx * ry - dy * rx < 0.0:
                            inside = False
                        # side face: segment x [0, h]
                        dz = max(0.0, max(z - h, -z))
                        dface = math.sqrt(d * d + dz * dz)
                        if dface < best:
                            best = dface
                            btex = ptex[p]
                            bu = tt * math.sqrt(L2)
                            bv = min(h, max(0.0, z))
                        if d < dmin:
                            dmin = d
                    d2 = -dmin if inside else dmin
                    dzz = max(z - h, -z)
                    o0 = max(d2, 0.0)
                    o1 = max(dzz, 0.0)
                    sdf = min(max(d2, dzz), 0.0) + math.sqrt(o0 * o0 + o1 * o1)
                    if -sdf > s:
                        s = -sdf
                    if h < height - 1e-9:  # obstacle top
                        dtop = abs(z - h) if inside else math.sqrt(dmin * dmin + (z - h) * (z - h))
                        if dtop < best:
                            best = dtop
                            btex = ptex[p]
                            bu = x
                            bv = y
                o = tau + 0.5 * s / ramp
                occ[ix, iy, iz] = min(tau + 0.5, max(tau - 0.5, o))
                texture_colour(btex, bu, bv, kind, base, amp, waves, rgb)
                for c in range(3):
                    col[ix, iy, iz, c] = rgb[c]
    return occ, col
