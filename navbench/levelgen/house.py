"""House levels: binary space partition into rooms, doors on a spanning tree, furniture."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navbench.errors import ConfigError, LevelError
from navbench.geometry import LEVEL_HEIGHT
from navbench.level import Level, Obstacle, Wall
from navbench.levelgen.common import DEFAULT_SIZE, DOOR_WIDTH, GENERATOR_VERSION, MAX_ATTEMPTS, MAX_CUTAWAY, OBSTACLE_GAP, WALL_THICKNESS, _AttemptFailed, _Rect, _T_CM, _ccw_tuple, _ceiling_texture, _cm, _colour_walls, _exterior_texture, _floor_texture, _palette, _q, _rect_gap, _rects_overlap
from navbench.levelgen.validate import validate_level

# ----------------------------------------------------------------------------------- houses

def _bsp_rooms(rng: np.random.Generator, W: int, D: int, count: int, corridor: bool,
               min_room: int = 190) -> tuple[list[_Rect], int | None]:
    """Split the centre-line box into ``count`` rectangles (cm); returns (rects, corridor index)."""
    h = _T_CM // 2
    root = _Rect(h, h, W - h, D - h)
    rects: list[_Rect] = [root]
    corr: _Rect | None = None
    if corridor and count >= 4:
        cw = int(rng.integers(120, 151))
        horizontal = root.w < root.h  # the corridor runs along the longer side
        length = root.h if horizontal else root.w
        pos = int(round(length * rng.uniform(0.35, 0.6) / 5.0)) * 5
        if horizontal:
            a = _Rect(root.x0, root.y0, root.x1, root.y0 + pos)
            corr = _Rect(root.x0, root.y0 + pos, root.x1, root.y0 + pos + cw)
            b = _Rect(root.x0, root.y0 + pos + cw, root.x1, root.y1)
        else:
            a = _Rect(root.x0, root.y0, root.x0 + pos, root.y1)
            corr = _Rect(root.x0 + pos, root.y0, root.x0 + pos + cw, root.y1)
            b = _Rect(root.x0 + pos + cw, root.y0, root.x1, root.y1)
        if min(a.w, a.h, b.w, b.h) < min_room:
            raise _AttemptFailed("corridor leaves too little room")
        rects = [a, b]
    target = count - (1 if corr is not None else 0)
    while len(rects) < target:
        cands = [r for r in rects if max(r.w, r.h) >= 2 * min_room]
        if not cands:
            raise _AttemptFailed("cannot split rooms further")
        wts = np.array([float(r.area) ** 1.5 for r in cands])
        r = cands[int(rng.choice(len(cands), p=wts / wts.sum()))]
        if r.w >= 2 * min_room and r.h >= 2 * min_room and max(r.w, r.h) < 1.3 * min(r.w, r.h):
            vertical = bool(rng.random() < 0.5)
        else:
            vertical = r.w >= r.h
        length = r.w if vertical else r.h
        lo, hi = max(min_room, int(0.3 * length)), min(length - min_room, int(0.7 * length))
        if lo > hi:
            raise _AttemptFailed("room too small to split")
        pos = int(round(rng.uniform(lo, hi) / 5.0)) * 5
        pos = min(max(pos, lo), hi)
        rects.remove(r)
        if vertical:
            rects += [_Rect(r.x0, r.y0, r.x0 + pos, r.y1), _Rect(r.x0 + pos, r.y0, r.x1, r.y1)]
        else:
            rects += [_Rect(r.x0, r.y0, r.x1, r.y0 + pos), _Rect(r.x0, r.y0 + pos, r.x1, r.y1)]
    rects.sort(key=lambda q: (q.y0, q.x0))
    if corr is not None:
        rects.append(corr)
        return rects, len(rects) - 1
    return rects, None


def _shared_boundary(a: _Rect, b: _Rect) -> tuple[str, int, int, int] | None:
    """``(axis, c, lo, hi)``: a shared wall on the line ``x = c`` (axis "x", the wall's normal)
    or ``y = c`` (axis "y") spanning ``[lo, hi]`` (cm), or None."""
    for c_a, c_b in ((a.x1, b.x0), (a.x0, b.x1)):
        if c_a == c_b:
            lo, hi = max(a.y0, b.y0), min(a.y1, b.y1)
            if hi > lo:
                return ("x", c_a, lo, hi)
    for c_a, c_b in ((a.y1, b.y0), (a.y0, b.y1)):
        if c_a == c_b:
            lo, hi = max(a.x0, b.x0), min(a.x1, b.x1)
            if hi > lo:
                return ("y", c_a, lo, hi)
    return None


def _union(intervals: list[tuple[int, int]]) -> list[tuple[int, int]]:
    out: list[tuple[int, int]] = []
    for lo, hi in sorted(intervals):
        if out and lo <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return out


def _subtract(intervals: list[tuple[int, int]], gaps: list[tuple[int, int]]) -> list[tuple[int, int]]:
    out = intervals
    for g0, g1 in gaps:
        nxt = []
        for lo, hi in out:
            if g1 <= lo or g0 >= hi:
                nxt.append((lo, hi))
                continue
            if g0 > lo:
                nxt.append((lo, g0))
            if g1 < hi:
                nxt.append((g1, hi))
        out = nxt
    return out


def _find(parent: list[int], i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@dataclass(frozen=True)
class HouseStyle:
    """The floor-plan statistics a house level is drawn from (:data:`HOUSE_STYLES`).

    ``rooms``: the range the room count is drawn from when not given (inclusive);
    ``min_room`` (cm): the smallest room side, ``None`` for the house style's 190 (up to 6 rooms)
    or 170; ``corridor`` / ``cutaway``: the probability of a corridor along the first split and
    of cut-away corner rooms (making the outline non-rectangular); ``cutaways``: at most this
    many corners cut away (the partition draws that many extra rectangles; one left over when
    fewer corners qualify stays a room, so a level may have one room more than drawn);
    ``door_width`` (m): the range of door gaps; ``wide_door``: the
    probability of a wider opening (1.4-2.2 m) where the wall allows one; ``extra_door`` /
    ``extra_door_corridor``: the probability of a door beyond the spanning tree (a loop) between
    two rooms / a room and the corridor.
    """

    name: str
    rooms: tuple[int, int]
    min_room: int | None
    corridor: float
    cutaway: float
    cutaways: int
    door_width: tuple[float, float]
    wide_door: float
    extra_door: float
    extra_door_corridor: float


#: ``house``: the committed benchmark houses (their draws are unchanged, so they regenerate byte
#: for byte). ``dense``: closer to the HouseExpo floor plans of the paper (issue 16: "more and
#: smaller rooms, corridors, non-rectangular outlines, doors from 0.8 m"): 8-12 rooms of at least
#: 1.5 m, always a corridor, up to two corners cut away, doors 0.8-0.95 m with no wide openings,
#: and few loops (a real house reaches most rooms through one door). Chosen from that description
#: before any episode ran on such a level, not tuned.
HOUSE_STYLES: dict[str, HouseStyle] = {
    "house": HouseStyle("house", (4, 8), None, 0.55, 0.4, 1, DOOR_WIDTH, 0.15, 0.2, 0.6),
    "dense": HouseStyle("dense", (8, 12), 150, 1.0, 1.0, 2, (0.8, 0.95), 0.0, 0.1, 0.4),
}


def _house_attempt(rng: np.random.Generator, name: str, seed: int, size: float,
                   rooms: int | None, obstacles: int | None, attempt: int,
                   style: HouseStyle = HOUSE_STYLES["house"]) -> Level:
    S = int(round(size * 100))
    long_side = S
    short_side = int(round(S * rng.uniform(0.72, 1.0) / 5.0)) * 5
    W, D = (long_side, short_side) if rng.random() < 0.5 else (short_side, long_side)
    n_rooms = int(rng.integers(style.rooms[0], style.rooms[1] + 1)) if rooms is None else rooms
    n_obs = (min(25, int(rng.integers(n_rooms + 4, 2 * n_rooms + 7))) if obstacles is None
             else obstacles)
    if style.min_room is not None:
        min_room = style.min_room
    else:
        min_room = 190 if n_rooms <= 6 else 170
    use_corridor = bool(rng.random() < style.corridor)
    use_void = n_rooms >= 4 and bool(rng.random() < style.cutaway)
    # the room count includes the corridor; cut-away corners are extra rectangles
    n_void = style.cutaways if use_void else 0
    rects, corr = _bsp_rooms(rng, W, D, n_rooms + n_void, use_corridor, min_room)

    # adjacency between rooms
    n = len(rects)
    bounds: dict[tuple[int, int], tuple[str, int, int, int]] = {}
    for i in range(n):
        for j in range(i + 1, n):
            b = _shared_boundary(rects[i], rects[j])
            if b is not None:
                bounds[(i, j)] = b

    voids: list[int] = []
    h = _T_CM // 2
    for _ in range(n_void):
        # a corner room (touching two outer sides), not the corridor, whose removal keeps the rest
        # connected through door-sized boundaries; together the cut-away rooms stay within
        # MAX_CUTAWAY of the footprint
        cut = sum(rects[v].area for v in voids)
        corners = [i for i, r in enumerate(rects) if i != corr and i not in voids
                   and (r.x0 == h or r.x1 == W - h) and (r.y0 == h or r.y1 == D - h)
                   and cut + r.area <= MAX_CUTAWAY * W * D]
        if corners:
            voids.append(corners[int(rng.integers(len(corners)))])

    margin = 30  # cm between a door and the end of its wall
    min_door = int(style.door_width[0] * 100)
    live = [i for i in range(n) if i not in voids]
    eligible = [(i, j) for (i, j), b in bounds.items()
                if i not in voids and j not in voids and b[3] - b[2] >= min_door + 2 * margin]
    order = rng.permutation(len(eligible)).tolist()
    parent = list(range(n))
    chosen: list[tuple[int, int]] = []
    for k in order:
        i, j = eligible[k]
        ri, rj = _find(parent, i), _find(parent, j)
        if ri != rj:
            parent[ri] = rj
            chosen.append((i, j))
    if len({_find(parent, i) for i in live}) != 1:
        raise _AttemptFailed("rooms cannot all be joined by doors")
    for k in order:
        e = eligible[k]
        if e in chosen:
            continue
        p = style.extra_door_corridor if corr in e else style.extra_door
        if rng.random() < p:
            chosen.append(e)
    chosen.sort()

    # doors: (axis, line, lo, hi) gap along the line
    doors = []
    for e in chosen:
        axis, c, lo, hi = bounds[e]
        span = hi - lo - 2 * margin
        if span >= 160 and rng.random() < style.wide_door:
            w = int(rng.integers(140, min(220, span) + 1))
        else:
            w = int(rng.integers(min_door, min(int(style.door_width[1] * 100), span) + 1))
        cmin, cmax = lo + margin + w / 2, hi - margin - w / 2
        centre = int(round(rng.uniform(cmin, cmax)))
        centre = int(min(max(centre, math.ceil(cmin)), math.floor(cmax)))
        doors.append((axis, c, centre - w // 2, centre - w // 2 + w, e))

    # walls: per line, the union of room boundaries minus door gaps; plus the outer walls
    lines: dict[tuple[str, int], list[tuple[int, int]]] = {}
    for (i, j), (axis, c, lo, hi) in bounds.items():
        lines.setdefault((axis, c), []).append((lo, hi))
    gaps: dict[tuple[str, int], list[tuple[int, int]]] = {}
    for axis, c, g0, g1, _ in doors:
        gaps.setdefault((axis, c), []).append((g0, g1))
    segs_cm: list[tuple[tuple[int, int], tuple[int, int]]] = []
    t2 = _T_CM // 2
    segs_cm += [((0, t2), (W, t2)), ((W - t2, 0), (W - t2, D)),
                ((W, D - t2), (0, D - t2)), ((t2, D), (t2, 0))]
    for (axis, c) in sorted(lines):
        for lo, hi in _subtract(_union(lines[(axis, c)]), sorted(gaps.get((axis, c), []))):
            segs_cm.append(((c, lo), (c, hi)) if axis == "x" else ((lo, c), (hi, c)))
    segs = [((_cm(a[0]), _cm(a[1])), (_cm(b[0]), _cm(b[1]))) for a, b in segs_cm]

    # textures: 0 floor, 1 ceiling, 2 exterior, then walls, then obstacles
    n_wall_tex = 9
    n_obs_tex = 6
    textures = [_floor_texture(rng), _ceiling_texture(rng), _exterior_texture()]
    textures += _palette(rng, n_wall_tex)
    textures += _palette(rng, n_obs_tex, sat=(0.4, 0.75), val=(0.35, 0.7))
    wtex = _colour_walls(rng, segs, n_wall_tex)
    walls = [Wall(a, b, WALL_THICKNESS, 3 + k) for (a, b), k in zip(segs, wtex)]

    # exterior fill for the cut-away room
    obs_list: list[Obstacle] = []
    exterior: list[int] = []
    for v in voids:
        r = rects[v].metres()
        exterior.append(len(obs_list))
        obs_list.append(Obstacle(_ccw_tuple([(r[0], r[1]), (r[2], r[1]), (r[2], r[3]), (r[0], r[3])]),
                                 LEVEL_HEIGHT, 2))

    # furniture
    keepouts = []
    for axis, c, g0, g1, _ in doors:
        a0, a1 = _cm(g0) - 0.3, _cm(g1) + 0.3
        cc = _cm(c)
        keepouts.append((cc - 1.0, a0, cc + 1.0, a1) if axis == "x" else (a0, cc - 1.0, a1, cc + 1.0))
    host_rooms = [i for i in live if i != corr]
    furniture = _place_furniture(rng, [rects[i] for i in host_rooms], keepouts, n_obs,
                                 first_texture=3 + n_wall_tex, n_textures=n_obs_tex)
    obs_list += furniture

    room_meta = [rects[i].metres() for i in live]
    door_meta = [{"center": [_cm((g0 + g1) / 2) if axis == "y" else _cm(c),
                             _cm(c) if axis == "y" else _cm((g0 + g1) / 2)],
                  "width": _cm(g1 - g0), "axis": axis,
                  "rooms": [live.index(e[0]), live.index(e[1])]}
                 for axis, c, g0, g1, e in doors]
    meta = {
        "generator": "navbench.levelgen.house", "version": GENERATOR_VERSION,
        "kind": style.name, "size": _q(size), "rooms_requested": rooms,
        "obstacles_requested": obstacles, "attempt": attempt,
        "rooms": room_meta,
        "corridor": live.index(corr) if corr is not None else None,
        "doors": door_meta, "exterior_obstacles": exterior,
    }
    level = Level(name=name, width=_cm(W), depth=_cm(D), walls=tuple(walls),
                  obstacles=tuple(obs_list), textures=tuple(textures), floor_texture=0,
                  ceiling_texture=1, height=LEVEL_HEIGHT, seed=seed, meta=meta)
    try:
        validate_level(level)
    except LevelError as e:
        raise _AttemptFailed(str(e)) from None
    return level


def _box(x0: float, y0: float, x1: float, y1: float) -> list[tuple[float, float]]:
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def _furniture_shape(rng: np.random.Generator) -> tuple[str, float, float, float]:
    """``(kind, a, b, height)``: a low box, a tall box (a along the wall) or a pillar (a = radius)."""
    u = rng.random()
    if u < 0.45:
        return ("box", _q(rng.uniform(0.5, 1.4), 0.01), _q(rng.uniform(0.4, 0.9), 0.01),
                _q(rng.uniform(0.2, 0.45), 0.01))
    if u < 0.8:
        return ("box", _q(rng.uniform(0.4, 1.0), 0.01), _q(rng.uniform(0.3, 0.6), 0.01),
                _q(rng.uniform(0.7, 1.2), 0.01))
    return ("pillar", _q(rng.uniform(0.1, 0.2), 0.01), 0.0, _q(rng.uniform(0.8, 1.2), 0.01))


def _rotated_shape(kind: str, a: float, b: float, cx: float, cy: float, ang: float,
                   sides: int) -> list[tuple[float, float]]:
    if kind == "pillar":
        return [(_q(cx + a * math.cos(ang + 2 * math.pi * k / sides)),
                 _q(cy + a * math.sin(ang + 2 * math.pi * k / sides))) for k in range(sides)]
    c, s = math.cos(ang), math.sin(ang)
    pts = []
    for px, py in ((-a / 2, -b / 2), (a / 2, -b / 2), (a / 2, b / 2), (-a / 2, b / 2)):
        pts.append((_q(cx + c * px - s * py), _q(cy + s * px + c * py)))
    return pts


def _place_furniture(rng: np.random.Generator, rooms: list[_Rect], keepouts: list, count: int,
                     first_texture: int, n_textures: int, tries: int = 300) -> list[Obstacle]:
    """Place ``count`` convex obstacles in ``rooms`` (rectangles in cm, wall centre lines).

    Each obstacle either stands flush against a wall (overlapping it by 2 cm, snapped into the
    corner when near one) or free with a gap of at least :data:`OBSTACLE_GAP` to the walls; its
    bounding box keeps that gap from every other obstacle's and avoids the door ``keepouts``.
    """
    if count <= 0:
        return []
    if not rooms:
        raise _AttemptFailed("no room for furniture")
    g = OBSTACLE_GAP
    t2 = WALL_THICKNESS / 2
    areas = np.array([float(r.area) for r in rooms])
    placed: list[tuple[list[tuple[float, float]], tuple[float, float, float, float], float]] = []
    for _ in range(count):
        for _try in range(tries):
            room = rooms[int(rng.choice(len(rooms), p=areas / areas.sum()))]
            rm = room.metres()
            R = (rm[0] + t2, rm[1] + t2, rm[2] - t2, rm[3] - t2)
            kind, a, b, height = _furniture_shape(rng)
            against = kind == "box" and rng.random() < 0.6
            if against:
                side = int(rng.integers(4))
                along_x = side in (0, 2)  # bottom/top walls
                L_room = (R[2] - R[0]) if along_x else (R[3] - R[1])
                depth_room = (R[3] - R[1]) if along_x else (R[2] - R[0])
                if a > L_room - g or b > depth_room - g - 0.1:
                    continue
                lo_a = (R[0] if along_x else R[1]) - 0.02
                hi_a = (R[2] if along_x else R[3]) + 0.02
                s0 = _q(rng.uniform(lo_a, hi_a - a), 0.01)
                if s0 - lo_a < g:
                    s0 = lo_a
                if hi_a - (s0 + a) < g:
                    s0 = hi_a - a
                if side == 0:
                    bb = (s0, R[1] - 0.02, s0 + a, R[1] + b)
                elif side == 2:
                    bb = (s0, R[3] - b, s0 + a, R[3] + 0.02)
                elif side == 1:
                    bb = (R[2] - b, s0, R[2] + 0.02, s0 + a)
                else:
                    bb = (R[0] - 0.02, s0, R[0] + b, s0 + a)
                bb = tuple(_q(v) for v in bb)
                poly = _box(*bb)
            else:
                ang = _q(rng.uniform(0, math.pi), 1e-3)
                rad = a if kind == "pillar" else 0.5 * math.hypot(a, b)
                lo_x, hi_x = R[0] + g + rad, R[2] - g - rad
                lo_y, hi_y = R[1] + g + rad, R[3] - g - rad
                if lo_x > hi_x or lo_y > hi_y:
                    continue
                cx, cy = _q(rng.uniform(lo_x, hi_x), 0.01), _q(rng.uniform(lo_y, hi_y), 0.01)
                poly = _rotated_shape(kind, a, b, cx, cy, ang, 8 if rng.random() < 0.5 else 6)
                xs_ = [p[0] for p in poly]
                ys_ = [p[1] for p in poly]
                bb = (min(xs_), min(ys_), max(xs_), max(ys_))
                if bb[0] < R[0] + g or bb[1] < R[1] + g or bb[2] > R[2] - g or bb[3] > R[3] - g:
                    continue
            if any(_rects_overlap(bb, k) for k in keepouts):
                continue
            if any(_rect_gap(bb, q[1]) < g for q in placed):
                continue
            placed.append((poly, bb, height))
            break
        else:
            raise _AttemptFailed("could not place all obstacles")
    out = []
    for poly, _, height in placed:
        out.append(Obstacle(_ccw_tuple(poly), height, first_texture + int(rng.integers(n_textures))))
    return out


def _check_name_seed(name: str, seed: int) -> None:
    from navbench.names import check_name

    check_name("level name", name, ConfigError)  # it becomes levels/NAME.json
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"seed must be a non-negative integer, got {seed!r}")


def _retry(make, name: str, seed: int, max_attempts: int) -> Level:
    last = ""
    for attempt in range(max_attempts):
        rng = np.random.default_rng((seed, attempt))
        try:
            return make(rng, attempt)
        except _AttemptFailed as e:
            last = str(e)
    raise LevelError(f"could not generate a valid level {name!r} from seed {seed} in "
                     f"{max_attempts} attempts (last problem: {last})")


def generate_level(name: str, seed: int, size: float = DEFAULT_SIZE, rooms: int | None = None,
                   obstacles: int | None = None, max_attempts: int = MAX_ATTEMPTS,
                   style: str = "house") -> Level:
    """A HouseExpo-like house level (see the module docstring), valid per :func:`validate_level`.

    ``size`` (m): the longer side of the footprint (the other is 72-100 % of it); ``rooms``: the
    number of rooms including a corridor (drawn from the style's range when None); ``obstacles``:
    the number of furniture obstacles (drawn when None); ``style``: a key of
    :data:`HOUSE_STYLES` (``house``, the committed houses; ``dense``, more and smaller rooms).
    Attempt ``k`` draws from ``numpy.random.default_rng((seed, k))``; the first valid attempt
    is returned.
    """
    _check_name_seed(name, seed)
    if style not in HOUSE_STYLES:
        raise ConfigError(f"unknown house style {style!r}; choose one of {sorted(HOUSE_STYLES)}")
    st = HOUSE_STYLES[style]
    if not (isinstance(size, (int, float)) and math.isfinite(size) and 5.0 <= size <= 30.0):
        raise ConfigError(f"size must be between 5 and 30 m, got {size!r}")
    if rooms is not None and not (isinstance(rooms, int) and 1 <= rooms <= 16):
        raise ConfigError(f"rooms must be an integer in [1, 16], got {rooms!r}")
    if obstacles is not None and not (isinstance(obstacles, int) and 0 <= obstacles <= 40):
        raise ConfigError(f"obstacles must be an integer in [0, 40], got {obstacles!r}")
    return _retry(lambda rng, k: _house_attempt(rng, name, seed, float(size), rooms, obstacles, k, st),
                  name, seed, max_attempts)
