"""Navigation tasks (paper section 5, appendix D): sampling, and the task-set file format.

A task is a start pose and a target position sampled uniformly in the free space of the TRUE
geometry, both at least ``1.2 L`` from every solid, farther apart than ``3 L``, with the target
reachable from the start for the agent's disc (radius ``L / 2``). ``optimal_length`` is the
exact shortest feasible path (:mod:`navbench.plan.shortest`), the ``l_i`` of SPL.

Task file (``tasks/<level>-<count>-<hash8>.json``, ``hash8`` the first 8 hex digits of the
sha256 of the file text)::

    {"format": "navbench-tasks", "version": 1, "level": "house-1",
     "level_sha256": "<sha256 of the level file text>", "seed": 0, "count": 200,
     "agent_length": 0.2, "units": "metres, radians",
     "tasks": [{"id": 0, "start_x": .., "start_y": .., "start_heading": ..,
                "target_x": .., "target_y": .., "optimal_length": ..}, ...]}
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from navbench.config import read_json
from navbench.errors import TaskError
from navbench.geometry import AGENT_LENGTH, AGENT_RADIUS
from navbench.names import check_name

TASK_FORMAT = "navbench-tasks"
TASK_VERSION = 1
#: Minimum clearance (m) of start and target from every solid: 1.2 L.
MIN_CLEARANCE = 1.2 * AGENT_LENGTH
#: Start and target must be farther apart than this (m): 3 L.
MIN_SEPARATION = 3.0 * AGENT_LENGTH
_FIELDS = ("id", "start_x", "start_y", "start_heading", "target_x", "target_y", "optimal_length")
#: Largest task id: ids are stored as 64-bit integers (database rows, episode seeds).
MAX_TASK_ID = 2**63 - 1
#: How far (m) a stored point may fall short of :data:`MIN_CLEARANCE`: files round coordinates
#: to 1e-6 m, which moves a point by at most 7.1e-7 m.
CLEARANCE_TOLERANCE = 1e-6
#: How far (m) a stored ``optimal_length`` may differ from the recomputed exact shortest path:
#: rounding both endpoints (<= 7.1e-7 m each; the length is 1-Lipschitz in each) and the length
#: itself (<= 5e-7 m) changes it by under 2e-6 m; this allows five times that.
LENGTH_TOLERANCE = 1e-5


@dataclass(frozen=True)
class Task:
    """One navigation task. ``start = (x, y, theta)`` (m, m, rad), ``target = (x, y)`` (m),
    ``optimal_length`` the shortest feasible path length (m) for the agent's disc."""

    id: int
    start: tuple[float, float, float]
    target: tuple[float, float]
    optimal_length: float


@dataclass(frozen=True)
class TaskSet:
    """A task file's content: the level it belongs to, how it was sampled, and its tasks."""

    level: str
    level_sha256: str
    seed: int | None
    tasks: tuple[Task, ...]

    @property
    def count(self) -> int:
        return len(self.tasks)


def level_sha256(level_text: str) -> str:
    """sha256 hex digest of a level file's text."""
    return hashlib.sha256(level_text.encode()).hexdigest()


def _free_points(level, rng: np.random.Generator, min_clearance: float, batch: int = 256):
    """Endless stream of points uniform in the level box with clearance >= ``min_clearance``."""
    from navbench.level import distance_to_solids, prisms

    pr = prisms(level)
    lo = np.array([min_clearance, min_clearance])
    hi = np.array([level.width - min_clearance, level.depth - min_clearance])
    if np.any(hi <= lo):
        raise TaskError(f"level {level.name!r} is too small for tasks")
    tries = 0
    while True:
        pts = lo + rng.random((batch, 2)) * (hi - lo)
        ok = distance_to_solids(pr, pts) >= min_clearance
        tries += batch
        if tries > 200_000 and not ok.any():
            raise TaskError(f"level {level.name!r} has no free space with {min_clearance:g} m clearance")
        yield from pts[ok]


def sample_tasks(level, count: int = 200, seed: int = 0, min_clearance: float = MIN_CLEARANCE,
                 min_separation: float = MIN_SEPARATION, radius: float = AGENT_RADIUS,
                 max_tries: int = 100_000, geodesic_range: tuple[float, float] | None = None,
                 first_id: int = 0) -> list[Task]:
    """Sample ``count`` tasks in ``level`` (TRUE geometry), deterministic in ``seed``.

    Start and target are drawn uniformly in the level box among points with clearance
    ``>= min_clearance`` (m, exact :func:`navbench.level.distance_to_solids`); a pair is kept when
    the points are farther apart than ``min_separation`` (m) and the target is reachable for a
    disc of ``radius`` (m); the start heading is uniform in ``[-pi, pi)``. Rejected pairs are
    redrawn (this is rejection sampling, so the kept pairs stay uniform given the constraints).
    ``geodesic_range = (lo, hi)`` (m) also rejects pairs whose exact shortest path is outside
    ``[lo, hi]`` (NRNS difficulty, :func:`sample_tasks_by_difficulty`); ``seed`` may be anything
    :func:`numpy.random.default_rng` takes. Task ids start at ``first_id``.
    """
    from navbench.plan.shortest import graph_for_level, shortest_path

    if count < 0:
        raise TaskError(f"count must be >= 0, got {count}")
    rng = np.random.default_rng(seed)
    graph = graph_for_level(level, radius)
    points = _free_points(level, rng, min_clearance)
    tasks: list[Task] = []
    tries = 0
    while len(tasks) < count:
        tries += 1
        if tries > max_tries:
            raise TaskError(f"could not sample {count} tasks in {level.name!r} after {max_tries} tries")
        s, t = next(points), next(points)
        heading = float(rng.uniform(-math.pi, math.pi))
        if np.linalg.norm(t - s) <= min_separation:
            continue
        try:
            length, _ = shortest_path(graph, s, t)
        except TaskError:
            continue  # unreachable (another component) or not free for the disc
        if geodesic_range is not None and not geodesic_range[0] <= length <= geodesic_range[1]:
            continue
        tasks.append(Task(first_id + len(tasks), (float(s[0]), float(s[1]), heading),
                          (float(t[0]), float(t[1])), float(length)))
    return tasks


def sample_tasks_by_difficulty(level, count: int, seed: int, difficulties) -> list[Task]:
    """``count`` tasks per NRNS difficulty (names of :data:`navbench.nav.presets.DIFFICULTY_BANDS`:
    easy 1.5-3 m, medium 3-5 m, hard 5-10 m of exact geodesic start-goal distance), with the
    constraints of :func:`sample_tasks`; difficulty ``i`` of the list draws from the stream
    ``[seed, i]``, and the ids run on: ``0 .. count - 1`` the first difficulty, and so on."""
    from navbench.nav.presets import DIFFICULTY_BANDS

    tasks: list[Task] = []
    for i, name in enumerate(difficulties):
        if name not in DIFFICULTY_BANDS:
            raise TaskError(f"unknown difficulty {name!r}; choose from {', '.join(DIFFICULTY_BANDS)}")
        tasks += sample_tasks(level, count, [int(seed), i], geodesic_range=DIFFICULTY_BANDS[name],
                              first_id=len(tasks), max_tries=1_000_000)
    return tasks


# ----------------------------------------------------------------------------- file format

def _r(x: float, nd: int = 6) -> float:
    v = round(float(x), nd)
    return 0.0 if v == 0 else v


def dumps_tasks(level_name: str, tasks, level_hash: str = "", seed: int | None = None) -> str:
    """The deterministic JSON text of a task file (numbers rounded to 1e-6)."""
    doc = {
        "format": TASK_FORMAT,
        "version": TASK_VERSION,
        "level": level_name,
        "level_sha256": level_hash,
        "seed": seed,
        "count": len(tasks),
        "agent_length": AGENT_LENGTH,
        "units": "metres, radians",
        "tasks": [
            {"id": int(t.id), "start_x": _r(t.start[0]), "start_y": _r(t.start[1]),
             "start_heading": _r(t.start[2]), "target_x": _r(t.target[0]),
             "target_y": _r(t.target[1]), "optimal_length": _r(t.optimal_length)}
            for t in tasks
        ],
    }
    return json.dumps(doc, indent=1) + "\n"


def task_file_name(level_name: str, count: int, text: str) -> str:
    """``<level>-<count>-<hash8>.json`` with ``hash8`` from the sha256 of the file ``text``."""
    return f"{level_name}-{count}-{hashlib.sha256(text.encode()).hexdigest()[:8]}.json"


def save_tasks(path, level_name: str, tasks, level_hash: str = "", seed: int | None = None) -> Path:
    """Write a task file. ``path`` is a directory (the file is named by :func:`task_file_name`)
    or a file path. Returns the written path."""
    text = dumps_tasks(level_name, tasks, level_hash, seed)
    path = Path(path)
    if path.is_dir() or path.suffix == "":
        path = path / task_file_name(level_name, len(tasks), text)
    from navbench.outpath import write_text_atomic

    path.parent.mkdir(parents=True, exist_ok=True)
    return write_text_atomic(path, text)


def _short(x, limit: int = 60) -> str:
    r = repr(x)
    return r if len(r) <= limit else r[: limit - 3] + "..."


def _num(x, where: str, source: str) -> float:
    ok = not isinstance(x, bool) and isinstance(x, (int, float))
    if ok:
        try:
            ok = math.isfinite(x)
        except OverflowError:  # an integer too large for a float
            ok = False
    if not ok:
        raise TaskError(f"{source}: {where}: expected a finite number, got {_short(x)}")
    return float(x)


def task_set_from_dict(doc, source: str = "<tasks>") -> TaskSet:
    """Validate a task document; :class:`TaskError` names the bad field."""
    if not isinstance(doc, dict):
        raise TaskError(f"{source}: expected a JSON object")
    if doc.get("format") != TASK_FORMAT:
        raise TaskError(f"{source}: format: expected {TASK_FORMAT!r}, got {doc.get('format')!r}")
    if doc.get("version") != TASK_VERSION:
        raise TaskError(f"{source}: version: unknown version {doc.get('version')!r} (this navbench reads {TASK_VERSION})")
    level = doc.get("level")
    if not isinstance(level, str) or not level:
        raise TaskError(f"{source}: level: expected a non-empty string")
    check_name(f"{source}: level:", level, TaskError)
    lh = doc.get("level_sha256", "")
    if not isinstance(lh, str):
        raise TaskError(f"{source}: level_sha256: expected a string")
    seed = doc.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        raise TaskError(f"{source}: seed: expected an integer or null, got {_short(seed)}")
    if "agent_length" in doc:
        al = _num(doc["agent_length"], "agent_length", source)
        if abs(al - AGENT_LENGTH) > 1e-12:
            raise TaskError(f"{source}: agent_length: tasks sampled for an agent of {al:g} m, "
                            f"this navbench's agent is {AGENT_LENGTH:g} m")
    raw = doc.get("tasks")
    if not isinstance(raw, list):
        raise TaskError(f"{source}: tasks: expected a list")
    tasks = []
    ids = set()
    for i, t in enumerate(raw):
        where = f"tasks[{i}]"
        if not isinstance(t, dict):
            raise TaskError(f"{source}: {where}: expected an object")
        for f in _FIELDS:
            if f not in t:
                raise TaskError(f"{source}: {where}.{f}: missing field")
        tid = t["id"]
        if isinstance(tid, bool) or not isinstance(tid, int) or not 0 <= tid <= MAX_TASK_ID:
            raise TaskError(f"{source}: {where}.id: expected an integer in [0, 2**63 - 1], "
                            f"got {_short(tid)}")
        if tid in ids:
            raise TaskError(f"{source}: {where}.id: duplicate task id {tid}")
        ids.add(tid)
        v = {f: _num(t[f], f"{where}.{f}", source) for f in _FIELDS[1:]}
        if v["optimal_length"] <= 0:
            raise TaskError(f"{source}: {where}.optimal_length: expected a positive length, got {v['optimal_length']}")
        tasks.append(Task(tid, (v["start_x"], v["start_y"], v["start_heading"]),
                          (v["target_x"], v["target_y"]), v["optimal_length"]))
    count = doc.get("count")
    if isinstance(count, bool) or not isinstance(count, int) or count != len(tasks):
        raise TaskError(f"{source}: count: says {_short(count)} but the file holds {len(tasks)} tasks")
    return TaskSet(level, lh, seed, tuple(tasks))


def check_tasks_on_level(level, tasks, source: str = "<tasks>", radius: float = AGENT_RADIUS) -> None:
    """Raise :class:`TaskError` naming ``source: tasks[i].field`` unless every task is one that
    :func:`sample_tasks` could have drawn on ``level``.

    Each start and target must lie in the level box with clearance >= :data:`MIN_CLEARANCE`
    (less :data:`CLEARANCE_TOLERANCE`) from every solid, and each ``optimal_length`` must equal
    the exact shortest feasible path (:func:`navbench.plan.shortest.shortest_path`, recomputed
    from the stored points) within :data:`LENGTH_TOLERANCE`; an unreachable target is an error
    too. Otherwise an episode would start inside a wall, chase an unreachable target, or score
    an SPL against a made-up ``l_i``. (Separation is not checked: it only shapes the sample.)
    """
    from navbench.level import distance_to_solids, prisms
    from navbench.plan.shortest import graph_for_level, shortest_path

    tasks = list(tasks)
    if not tasks:
        return
    pr = prisms(level)
    starts = np.array([t.start[:2] for t in tasks], float)
    targets = np.array([t.target for t in tasks], float)
    need = MIN_CLEARANCE - CLEARANCE_TOLERANCE
    for name, pts in (("start", starts), ("target", targets)):
        inside = ((pts[:, 0] >= need) & (pts[:, 0] <= level.width - need)
                  & (pts[:, 1] >= need) & (pts[:, 1] <= level.depth - need))
        clear = np.zeros(len(pts))
        clear[inside] = distance_to_solids(pr, pts[inside])
        bad = np.flatnonzero(~inside | (clear < need))
        if len(bad):
            i = int(bad[0])
            x, y = pts[i]
            what = (f"({x:g}, {y:g}) lies outside the level {level.name!r} "
                    f"[0, {level.width:g}] x [0, {level.depth:g}] less the clearance"
                    if not inside[i] else
                    f"({x:g}, {y:g}) is {clear[i]:.4f} m from a wall or obstacle of level "
                    f"{level.name!r}; tasks need {MIN_CLEARANCE:g} m")
            more = f" (and {len(bad) - 1} more {name}s)" if len(bad) > 1 else ""
            raise TaskError(f"{source}: tasks[{i}].{name}_x, {name}_y: {what}{more}")
    graph = graph_for_level(level, radius)
    for i, t in enumerate(tasks):
        try:
            length, _ = shortest_path(graph, starts[i], targets[i])
        except TaskError as e:
            raise TaskError(f"{source}: tasks[{i}]: target not reachable from the start in level "
                            f"{level.name!r} ({e})") from None
        if abs(length - t.optimal_length) > LENGTH_TOLERANCE:
            raise TaskError(f"{source}: tasks[{i}].optimal_length: says {t.optimal_length:g} m but "
                            f"the shortest path in level {level.name!r} is {length:.6f} m")


def read_task_file(path) -> TaskSet:
    """Load and validate a task file with its metadata."""
    path = Path(path)
    return task_set_from_dict(read_json(path, TaskError, f"{path}: no such task file"), str(path))


def load_tasks(path) -> list[Task]:
    """The tasks of a task file (validated; see :func:`read_task_file` for the metadata)."""
    return list(read_task_file(path).tasks)


def _mtime(p: Path) -> float:
    """When ``p`` was changed: its target's time, else (a dangling link) the link's own, so that
    a broken task file is still found and then refused in one line by :func:`read_task_file`."""
    try:
        return p.stat().st_mtime
    except OSError:
        try:
            return p.lstat().st_mtime
        except OSError:
            return 0.0


def find_task_file(level_name: str, count: int | None = None, root=".") -> Path:
    """The committed task file ``tasks/<level>-<count>-*.json`` (the newest if several)."""
    pat = f"{level_name}-{count}-*.json" if count is not None else f"{level_name}-*.json"
    hits = sorted((Path(root) / "tasks").glob(pat), key=_mtime)
    if not hits:
        raise TaskError(f"no task file tasks/{pat}; run `navbench sample-tasks {level_name}`")
    return hits[-1]


def make_task_file(level_name_or_path: str, count: int = 200, seed: int = 0, out_dir=None,
                   root=".") -> tuple[Path, TaskSet]:
    """Sample ``count`` tasks for a level file and write the task file; return its path and content.

    The level is resolved by name (``<root>/levels/<name>.json``) or path; its file text's
    sha256 goes into the task file. ``out_dir`` (a folder, created if new) defaults to
    ``<root>/tasks``.
    """
    from navbench.levelio import read_level_file, level_path

    from navbench.safeio import names_a_file

    p = Path(level_name_or_path)
    if not names_a_file(level_name_or_path):
        check_name("level name", level_name_or_path, TaskError)
        p = level_path(level_name_or_path, root)
    from navbench.safeio import check_regular_file

    check_regular_file(p, TaskError, "level file")  # missing, a directory, a FIFO: one line
    level, text = read_level_file(p, name=p.stem)  # its name becomes the task file's name
    tasks = sample_tasks(level, count, seed)
    folder = Path(out_dir) if out_dir is not None else Path(root) / "tasks"
    try:  # out_dir is a folder, whatever its name (save_tasks takes a name with a suffix for a file)
        folder.mkdir(parents=True, exist_ok=True)
        out = save_tasks(folder, level.name, tasks, level_hash=level_sha256(text), seed=seed)
    except OSError as e:
        raise TaskError(f"{folder}: cannot write the task file ({e.strerror or e})") from None
    return out, TaskSet(level.name, level_sha256(text), seed, tuple(tasks))
