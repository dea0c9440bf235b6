"""How the camera evaluates the level's textures: per pixel (``procedural``), from texel tables
(``table``) or with a polynomial sine (``polynomial``).

The textures (:func:`navbench.level.surface_colour`) are ``clip(base + amp * P(u, v), 0, 1)``
with ``P`` a weighted sum of sines of ``2 pi (fu u + fv v) + phase``; three libm sines per pixel
are most of a frame (issue 36). The modes:

``procedural`` (default; every ``navbench-1`` image)
    ``P`` from libm's ``sin`` at every pixel: the images stored so far, bit for bit.
``table``
    ``P`` evaluated once per surface (the floor, the ceiling, each low prism's top, each side
    face of each prism) at texel centres ``origin + (i, j) * h`` with the procedural formula,
    and looked up bilinearly. At a texel centre the lookup is the procedural ``P`` exactly;
    elsewhere it is off by at most ``h**2 / 8 * (2 pi)**2 * sum_k w_k (fu_k**2 + fv_k**2)``
    (the bilinear interpolation bound, ``w_k`` the weights of the sines: 1/3 each for
    ``waves``, 0.7 and 0.3 for ``tiles``), times ``amp`` in colour (``clip`` does not grow
    it). ``h`` is the largest power of two that keeps that colour bound within
    :data:`TABLE_TOLERANCE` for every texture of the level (1/64 m for every committed level,
    bounds 1.3e-3 to 1.7e-3: their frequencies stay below 2.5 cycles/m), unless the tables would outgrow
    :data:`MAX_TABLE_BYTES` (then ``h`` doubles and :attr:`TexelTables.bound` says the
    bound it gives). A hit outside its surface's table (the floor seen beyond the level's
    box) falls back to the procedural formula.
``polynomial``
    ``P`` from :func:`poly_sin`: the argument reduced to ``[-pi, pi]`` and a degree-17
    odd Taylor polynomial (absolute error below ``4e-9`` on ``P``; no table, no build).

Depth and validity never depend on the mode: textures change colour only.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np
from numba import njit

from navbench.errors import ConfigError

#: The camera's texture modes; the first is the default and ``navbench-1``'s.
TEXTURE_MODES = ("procedural", "table", "polynomial")
DEFAULT_TEXTURE = "procedural"
#: Largest colour error (bilinear bound) a texel table may add: a half of one 8-bit level.
TABLE_TOLERANCE = 1.0 / 512
#: Texel tables of one level never take more memory than this (``h`` doubles until they fit).
MAX_TABLE_BYTES = 256 * 2**20
#: Coarsest texel tried before the memory cap (m).
_H_START = 1.0 / 8


def check_texture(value, where: str = "texture") -> str:
    """``value`` when it is a texture mode, else a one-line :class:`ConfigError`."""
    if value not in TEXTURE_MODES:
        raise ConfigError(f"{where}: expected one of {', '.join(TEXTURE_MODES)}, got {value!r}")
    return value


def texture_code(value) -> int:
    """The compiled kernels' integer for a mode (its index in :data:`TEXTURE_MODES`)."""
    return TEXTURE_MODES.index(check_texture(value))


# ------------------------------------------------------------------------------ compiled parts

@njit(cache=True, inline="always")
def pattern(t, u, v, kind, waves):
    """``P`` of texture ``t`` at ``(u, v)`` with libm sines: the same operations, in the same
    order, as :func:`navbench.sim.camera._texel`."""
    two_pi = 2.0 * math.pi
    if kind[t] == 0:
        p = 0.0
        for k in range(3):
            p += math.sin(two_pi * (waves[t, k, 0] * u + waves[t, k, 1] * v) + waves[t, k, 2])
        return p / 3.0
    p = 0.7 * math.sin(two_pi * waves[t, 0, 0] * u + waves[t, 0, 2]) * \
        math.sin(two_pi * waves[t, 0, 1] * v + waves[t, 0, 2])
    return p + 0.3 * math.sin(two_pi * (waves[t, 1, 0] * u + waves[t, 1, 1] * v) + waves[t, 1, 2])


@njit(cache=True, inline="always")
def poly_sin(x):
    """``sin(x)``: ``x`` reduced to ``r`` in ``[-pi, pi]`` and the odd Taylor polynomial of
    degree 17 (remainder ``pi**19 / 19! < 2.4e-8`` at the ends, far less inside)."""
    k = math.floor(x * 0.15915494309189535 + 0.5)
    r = x - k * 6.283185307179586
    r2 = r * r
    return r * (1.0 + r2 * (-1.0 / 6 + r2 * (1.0 / 120 + r2 * (-1.0 / 5040 + r2 * (
        1.0 / 362880 + r2 * (-1.0 / 39916800 + r2 * (1.0 / 6227020800 + r2 * (
            -1.0 / 1307674368000 + r2 * (1.0 / 355687428096000)))))))))


@njit(cache=True, inline="always")
def pattern_poly(t, u, v, kind, waves):
    """:func:`pattern` with :func:`poly_sin` instead of libm's sine."""
    two_pi = 2.0 * math.pi
    if kind[t] == 0:
        p = 0.0
        for k in range(3):
            p += poly_sin(two_pi * (waves[t, k, 0] * u + waves[t, k, 1] * v) + waves[t, k, 2])
        return p / 3.0
    p = 0.7 * poly_sin(two_pi * waves[t, 0, 0] * u + waves[t, 0, 2]) * \
        poly_sin(two_pi * waves[t, 0, 1] * v + waves[t, 0, 2])
    return p + 0.3 * poly_sin(two_pi * (waves[t, 1, 0] * u + waves[t, 1, 1] * v) + waves[t, 1, 2])


@njit(cache=True, inline="always")
def table_pattern(s, t, u, v, kind, waves, origin, shape, values, inv_h):
    """``P`` of surface ``s`` (texture ``t``) at ``(u, v)``: bilinear in its texel table, the
    procedural :func:`pattern` outside it. At a texel centre the weights are exactly 1 and 0."""
    nu = shape[s, 1]
    nv = shape[s, 2]
    fu = (u - origin[s, 0]) * inv_h
    fv = (v - origin[s, 1]) * inv_h
    if fu >= 0.0 and fv >= 0.0 and fu < nu - 1 and fv < nv - 1:
        iu = int(fu)
        iv = int(fv)
        au = fu - iu
        av = fv - iv
        o = shape[s, 0] + iu * nv + iv
        return (1.0 - au) * ((1.0 - av) * values[o] + av * values[o + 1]) + \
            au * ((1.0 - av) * values[o + nv] + av * values[o + nv + 1])
    return pattern(t, u, v, kind, waves)


@njit(cache=True)
def _fill(tex, origin, shape, h, kind, waves, values):
    for s in range(tex.shape[0]):
        nv = shape[s, 2]
        for i in range(shape[s, 1]):
            u = origin[s, 0] + i * h
            for j in range(nv):
                values[shape[s, 0] + i * nv + j] = pattern(tex[s], u, origin[s, 1] + j * h, kind, waves)


@njit(cache=True)
def _lookup(surf, tex, u, v, kind, waves, origin, shape, values, inv_h, out):
    for n in range(u.shape[0]):
        out[n] = table_pattern(surf[n], tex[n], u[n], v[n], kind, waves, origin, shape, values, inv_h)


@njit(cache=True)
def _poly(tex, u, v, kind, waves, out):
    for n in range(u.shape[0]):
        out[n] = pattern_poly(tex[n], u[n], v[n], kind, waves)


@njit(cache=True)
def _procedural(tex, u, v, kind, waves, out):
    for n in range(u.shape[0]):
        out[n] = pattern(tex[n], u[n], v[n], kind, waves)


# ------------------------------------------------------------------------------ tables

@dataclass(frozen=True)
class TexelTables:
    """Every surface's texel table of a level (see the module docstring).

    Surfaces: 0 the floor, 1 the ceiling, ``2 + p`` the top of prism ``p`` (an empty table for
    a full-height prism, whose top is never seen), ``2 + P + k`` the side face entered through
    edge ``k`` (``verts[k] -> verts[k + 1]`` of :func:`navbench.level.prisms`). ``texture (S,)``
    their texture, ``origin (S, 2)`` the ``(u, v)`` of texel ``(0, 0)`` (a multiple of ``h``),
    ``shape (S, 3)`` int64 ``(offset, nu, nv)`` into ``values`` (``P`` at texel ``(i, j)`` is
    ``values[offset + i * nv + j]``). ``bound``: the colour error bound at this ``h``.
    """

    h: float
    texture: np.ndarray
    origin: np.ndarray
    shape: np.ndarray
    values: np.ndarray
    bound: float

    @property
    def nbytes(self) -> int:
        return int(self.values.nbytes)


def pattern_curvature(level) -> np.ndarray:
    """Per texture ``(T,)``: ``sum_k w_k (fu_k**2 + fv_k**2)`` (cycles/m squared), so that the
    bilinear error of ``P`` at texel ``h`` is at most ``h**2 / 8 * (2 pi)**2`` times it."""
    out = np.zeros(len(level.textures))
    for t, tex in enumerate(level.textures):
        w = np.asarray(tex.waves, dtype=np.float64)
        weights = [1.0 / len(w)] * len(w) if tex.kind == "waves" else [0.7, 0.3]
        out[t] = sum(c * (w[k, 0] ** 2 + w[k, 1] ** 2) for k, c in enumerate(weights))
    return out


def colour_bound(level, h: float) -> float:
    """Largest colour error (any channel) the texel tables of ``level`` may add at texel ``h``."""
    amp = np.array([max(abs(a) for a in tex.amp) for tex in level.textures])
    return float(np.max(amp * pattern_curvature(level)) * h * h / 8.0 * (2.0 * math.pi) ** 2) \
        if len(amp) else 0.0


def _domains(level):
    """``(texture, umin, umax, vmin, vmax)`` of every surface, in surface order."""
    from navbench.level import prisms

    pr = prisms(level)
    W, D, Hl = float(level.width), float(level.depth), float(level.height)
    out = [(level.floor_texture, 0.0, W, 0.0, D), (level.ceiling_texture, 0.0, W, 0.0, D)]
    for p in range(len(pr)):
        poly = pr.polygon(p)
        if pr.height[p] < Hl:
            lo, hi = poly.min(axis=0), poly.max(axis=0)
            out.append((int(pr.texture[p]), lo[0], hi[0], lo[1], hi[1]))
        else:
            out.append((int(pr.texture[p]), 0.0, -1.0, 0.0, -1.0))  # empty
    for p in range(len(pr)):
        poly = pr.polygon(p)
        for e in range(len(poly)):
            length = float(np.linalg.norm(poly[(e + 1) % len(poly)] - poly[e]))
            out.append((int(pr.texture[p]), 0.0, length, 0.0, min(float(pr.height[p]), Hl)))
    return out


def _layout(domains, h: float):
    """Origins and ``(offset, nu, nv)`` of the domains at texel ``h``: one texel of margin."""
    origin = np.zeros((len(domains), 2))
    shape = np.zeros((len(domains), 3), np.int64)
    off = 0
    for s, (_, u0, u1, v0, v1) in enumerate(domains):
        if u1 < u0:
            continue
        ou, ov = (math.floor(u0 / h) - 1) * h, (math.floor(v0 / h) - 1) * h
        nu, nv = int(math.ceil((u1 - ou) / h)) + 2, int(math.ceil((v1 - ov) / h)) + 2
        origin[s] = ou, ov
        shape[s] = off, nu, nv
        off += nu * nv
    return origin, shape, off


def build_texel_tables(level, tolerance: float = TABLE_TOLERANCE,
                       max_bytes: int = MAX_TABLE_BYTES) -> TexelTables:
    """The texel tables of ``level``: ``h`` the largest power of two (m) whose colour bound is
    within ``tolerance``, coarsened until the tables fit in ``max_bytes``."""
    from navbench.level import texture_table

    h = _H_START
    while colour_bound(level, h) > tolerance and h > 2.0 ** -20:
        h /= 2
    domains = _domains(level)
    origin, shape, total = _layout(domains, h)
    while total * 8 > max_bytes:
        h *= 2
        origin, shape, total = _layout(domains, h)
    kind, _, _, waves = texture_table(level)
    tex = np.array([d[0] for d in domains], np.int64)
    values = np.empty(total)
    _fill(tex, origin, shape, h, kind, waves, values)
    return TexelTables(h, tex, origin, shape, values, colour_bound(level, h))


_MEMO: dict[int, tuple] = {}


def texel_tables(level) -> TexelTables:
    """:func:`build_texel_tables` once per level object (the episodes of a worker share one)."""
    hit = _MEMO.get(id(level))
    if hit is not None and hit[0]() is level:
        return hit[1]
    tables = build_texel_tables(level)
    if len(_MEMO) >= 4:
        _MEMO.clear()
    _MEMO[id(level)] = (weakref.ref(level), tables)
    return tables


# ------------------------------------------------------------------------------ numpy side

def surface_pattern(level, texture: str, surface, tex, u, v) -> np.ndarray:
    """``P`` at ``(u, v)`` of surfaces ``surface`` (texture indices ``tex``) in mode ``texture``
    (1-D arrays): what the camera's kernel computes, for :func:`render_reference`."""
    from navbench.level import texture_table

    kind, _, _, waves = texture_table(level)
    u = np.ascontiguousarray(u, dtype=np.float64)
    v = np.ascontiguousarray(v, dtype=np.float64)
    tex = np.ascontiguousarray(tex, dtype=np.int64)
    out = np.empty(u.shape[0])
    if check_texture(texture) == "procedural":  # the compiled libm pattern (the camera's own)
        _procedural(tex, u, v, kind, waves, out)
    elif texture == "table":
        tb = texel_tables(level)
        _lookup(np.ascontiguousarray(surface, dtype=np.int64), tex, u, v, kind, waves, tb.origin,
                tb.shape, tb.values, 1.0 / tb.h, out)
    else:
        _poly(tex, u, v, kind, waves, out)
    return out
