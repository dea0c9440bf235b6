"""The unknown-house image-goal episode (issue 15 section 3) at the TRUE pose; in the pipeline:
``run-navigation --goal image --map online|online-fused`` (:mod:`navbench.pipeline.stages.online`).

What the agent knows. It starts with no map. With ``mapping="perfect"`` (the default), after
every step its camera frame *reveals* the planning-grid cells it saw (:func:`reveal_frame`:
along each image column's horizontal direction, every cell up to the farthest valid pixel of
the column); what it knows about a seen cell is the truth (the level voxelised on the world
model's grid, :func:`voxelize_level`), so mapping is perfect and only *coverage* is earned.
With ``mapping="fused"`` every frame is fused into a TSDF voxel map instead and the agent plans
and matches on what it measured (:class:`_Mapper`). The pose is the simulator's (no tracking
noise). Everything the agent decides comes from the seen map and the goal image: no oracle.

The loop (:func:`run_unknown_image_episode`), per step:

0. at the start, the agent turns once around in place (``look_around`` steps; the camera sees
   94 degrees and unseen space is an obstacle, so it could not plan out of its first view);
1. every ``match_every`` steps (and on arrival at a matched goal) the localiser is rebuilt on the
   seen map (:class:`SeenMap`: unseen columns are empty, its occupancy slice marks them occupied
   so the lattice covers seen free space only) and the :class:`~navbench.nav.stop.GoalStopper`
   updates: a stop ends the episode; a ``"matched"`` goal, or a ``"weak"`` one of confidence
   >= ``inspect_confidence`` not inspected before, sends the agent there (A* on the seen free
   space); on arrival it turns to the matched heading and matches again (the stopper needs two
   consecutive matches: the one that sent it and this one; after a first match at the place it
   turns one step, 11.5 degrees, so the second comes from another view and a grown map); a
   place that does not then stop the agent is not inspected again. A weaker match (confidence >= ``goal_min_confidence``) becomes the explorer's
   goal score, ``confidence * exp(-d^2 / (2 goal_sigma^2))`` around the matched pose (RNR-Map's
   latent score, from the localiser instead of a learned heat map);
2. without a path, the :class:`~navbench.plan.explore.Explorer` picks a frontier viewpoint;
   ``"done"`` ends the episode (``"explored"``: the house is seen and the goal never matched);
3. the waypoint controller (``navbench.nav.controller``) steps towards the path; a collision ends
   the episode (``"stuck"``).

Scoring (:func:`score_image_episode`) is the ``nrns`` preset of issue 15 section 4: success =
the agent stopped by its own decision within ``success_radius`` (1 m) Euclidean of the goal,
within ``max_steps`` (500); SPL with the task's exact shortest path length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA, Frame, Intrinsics, wrap_angle
from navbench.nav.controller import ControllerConfig, controller_step
from navbench.nav.episode import EpisodeRecord
from navbench.nav.stop import GoalStopper, StopConfig
from navbench.plan.astar import plan_path
from navbench.plan.explore import Explorer, ExplorerConfig, seen_free
from navbench.track.registry import checked_pose

END_REASONS = ("stopped", "step-limit", "stuck", "explored")


@dataclass(frozen=True)
class ImageNavConfig:
    """Episode settings; lengths in metres."""

    max_steps: int = 500                 # nrns: 500 steps
    success_radius: float = 1.0          # nrns: stopped within 1 m Euclidean (scoring only)
    match_every: int = 20                # steps between goal matches on the seen map
    lattice_step: float = 0.25           # the localiser's lattice on the seen map (default 0.125)
    goal_min_confidence: float = 0.5     # a weaker match than this does not guide exploration
    goal_sigma: float = 1.5              # m, spread of the goal score around the matched pose
    exploration_score: bool = True       # False: "goal scoring without exploration"
    goal_score: bool = True              # False: "exploration without goal scoring"
    inspect_confidence: float = 0.75     # a weak match this good is inspected from its own pose
    look_around: int = 32                # turn-in-place steps at the start (32 x 11.25 deg = 360)
    max_approaches: int = 6              # places approached (matched or inspected) per episode
    explorer: ExplorerConfig = field(default_factory=ExplorerConfig)
    stop: StopConfig = field(default_factory=StopConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)


@dataclass
class ImageEpisode:
    """One episode: ``true_poses (T + 1, 3)``, ``end_reason`` (one of :data:`END_REASONS`),
    ``matches`` (number of goal matches run), ``stop_step`` (-1 unless stopped), ``seen_share``
    (share of the level's free planning cells seen at the end), ``known (nx, ny)`` the seen
    cells, ``goal_pose (3,)`` the last matched goal pose or ``None``."""

    true_poses: np.ndarray
    end_reason: str
    matches: int
    stop_step: int
    seen_share: float
    known: np.ndarray
    goal_pose: np.ndarray | None
    match_log: list = field(default_factory=list)  # (step, status, confidence, rival, distance m)
    # (T, 3) the controls given to the simulator (turn rad, direction rad, speed m), and per-step
    # milliseconds: "sim" the simulator step, "estimate" the map update from its frame
    # (reveal_frame or the fusion), "plan" what the agent computed before that step (goal matching, explorer,
    # A*, controller)
    controls: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    timings_ms: dict = field(default_factory=dict)
    goal_status: str = "none"   # the last goal match's status (navbench.nav.stop.GoalMatch)
    goal_confidence: float = float("nan")  # and its confidence
    est_poses: np.ndarray | None = None  # (T + 1, 3) the poses the agent believed (None: the true ones)


@dataclass
class OnlineEpisodeRecord(EpisodeRecord):
    """An :class:`~navbench.nav.episode.EpisodeRecord` of the unknown-house loop in the pipeline
    (:mod:`navbench.pipeline.stages.online`), plus the last
    goal match (``goal_status`` of :class:`~navbench.nav.stop.GoalMatch`, its confidence, the
    matched pose's distance to the true target ``goal_err_m``, NaN without one), the goal
    ``goal_heading`` (rad), ``matches`` run, ``seen_share`` of the free cells seen and ``known
    (nx, ny)`` the seen cells."""

    goal_status: str = "none"
    goal_confidence: float = float("nan")
    goal_err_m: float = float("nan")
    goal_heading: float = float("nan")
    matches: int = 0
    seen_share: float = float("nan")
    known: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), bool))


class SeenMap:
    """A :class:`~navbench.worldmodel.base.WorldModel` view of ``full`` (a ``VoxelMap``) with only
    the ``known (nx, ny)`` columns: the others are empty (they render nothing) and count as
    occupied in :meth:`occupancy_slice` (nothing is planned or localised there)."""

    kind = "seen"

    def __init__(self, full, known: np.ndarray):
        from navbench.worldmodel.grid import VoxelMap

        occ = full.occ.copy()
        occ[~np.asarray(known, bool)] = min(float(full.occ.min()), full.tau - 0.5)
        self.vmap = VoxelMap(full.spec, occ, full.col, full.tau, dict(full.meta))
        self.known = np.asarray(known, bool)
        self.meta = self.vmap.meta
        self._tables = None

    def occupancy_slice(self, mode="band", z_low=0.05, z_high=1.0, height=CAMERA_HEIGHT):
        occ, xs, ys = self.vmap.occupancy_slice(mode, z_low, z_high, height)
        return occ | ~self.known, xs, ys

    def renderer(self, intrinsics, camera_height=CAMERA_HEIGHT, max_range=20.0, step=None):
        """A :class:`~navbench.worldmodel.fastrender.FastRenderer` of the seen map; its exact skip
        tables are built once per view and shared by its renderers (the localiser makes two: the
        bank's and the refinement's). The online map's cheaper block tables render the same
        images but slower here: measured, 2026-11-26."""
        from navbench.worldmodel.fastrender import FastRenderer, exact_skip_tables

        if self._tables is None:
            self._tables = exact_skip_tables(self.vmap.occ, self.vmap.tau)
        return FastRenderer(self.vmap, intrinsics, camera_height, max_range, step, skip_tables=self._tables)

    def content_hash(self) -> str:  # pragma: no cover - never cached
        import hashlib

        return hashlib.sha256(self.vmap.occ.tobytes() + self.known.tobytes()).hexdigest()

    def save(self, path):  # pragma: no cover - an in-memory view
        raise NotImplementedError("a SeenMap is not saved")

    @classmethod
    def load(cls, path):  # pragma: no cover
        raise NotImplementedError("a SeenMap is not loaded")


def reveal_frame(known: np.ndarray, xs, ys, pose, frame: Frame, intrinsics: Intrinsics, substeps: int = 4,
                 behind: float = 1.5) -> None:
    """Mark in ``known (nx, ny)`` (in place) the cells seen by ``frame`` taken from ``pose``:
    along each column's horizontal direction (and ``substeps`` directions between neighbouring
    columns, with the smaller of their two ranges), every cell up to ``behind`` cells past the
    column's farthest valid pixel (its horizontal distance from the camera). ``behind``: the
    sensor knows a thin layer behind a surface it sees is solid (1.5 cells, 0.086 m on a
    house's 0.057 m cells, less than a wall's 0.1 m); with only the surface's own cell, the
    trilinear occupancy of :class:`SeenMap` can stay below ``tau`` and walls render with holes."""
    depth = np.asarray(frame.depth, np.float64)
    valid = np.asarray(frame.valid, bool) & np.isfinite(depth)
    u = np.arange(intrinsics.width, dtype=np.float64)
    tan_u = (u - intrinsics.cx) / intrinsics.fx
    horiz = np.where(valid, depth, 0.0) * np.sqrt(1.0 + tan_u**2)[None, :]
    rng = horiz.max(axis=0)  # (W,) metres, 0 where the column saw nothing
    ang_u = float(pose[2]) - np.arctan(tan_u)
    k = np.arange(substeps)[None, :] / substeps
    ang = (ang_u[:-1, None] * (1 - k) + ang_u[1:, None] * k).ravel()
    r = np.repeat(np.minimum(rng[:-1], rng[1:]), substeps)
    ang, r = np.append(ang, ang_u[-1]), np.append(r, rng[-1])
    cell = float(xs[1] - xs[0])
    keep = r > 0
    ang, r = ang[keep], r[keep] + behind * cell
    if len(r) == 0:
        return
    n = int(math.ceil(r.max() / (0.5 * cell))) + 1
    t = np.linspace(0.0, 1.0, n)[None, :] * r[:, None]
    px = float(pose[0]) + np.cos(ang)[:, None] * t
    py = float(pose[1]) + np.sin(ang)[:, None] * t
    ix = np.floor((px - xs[0]) / cell + 0.5).astype(np.int64)
    iy = np.floor((py - ys[0]) / cell + 0.5).astype(np.int64)
    ok = (ix >= 0) & (iy >= 0) & (ix < known.shape[0]) & (iy < known.shape[1])
    known[ix[ok], iy[ok]] = True


MAPPINGS = ("perfect", "fused")


class _Mapper:
    """What the agent knows of the house: ``known (nx, ny)`` planning cells, ``occupied`` (the
    known obstacles) and ``model()`` (the world model the localiser matches against).

    ``perfect``: :func:`reveal_frame` marks the seen cells, what a seen cell holds is the truth
    (``full``). ``fused``: every frame is fused at the (true) pose into a
    :class:`~navbench.worldmodel.fusion.FusedMap` on ``full``'s grid (its default
    :class:`~navbench.worldmodel.fusion.FusionConfig`); ``occupied`` is its
    :func:`~navbench.worldmodel.fusion.seen_slice` (what the depth camera measured, never the
    truth) and ``known`` the slice's known cells plus the cells the frames' columns looked
    across (:func:`reveal_frame` up to the measured surface, ``behind = 0``). The camera cannot
    see the body band within ~0.6 m of itself (nor the floor there), so without the rays' 2D
    coverage the agent's own surroundings stay unknown and it cannot plan out of its first
    view; with it, a low obstacle that no frame measured on a ray's way is taken as free (the
    2D projection frontier exploration uses)."""

    def __init__(self, mapping: str, full, truth, xs, ys, intrinsics, camera_height, tracker=None):
        if mapping not in MAPPINGS:
            raise ValueError(f"mapping: expected one of {MAPPINGS}, got {mapping!r}")
        if tracker is not None and mapping != "fused":
            raise ValueError("a tracker tracks against the fused map: mapping must be 'fused'")
        self.mapping, self.full, self.truth, self.xs, self.ys = mapping, full, truth, xs, ys
        self.intrinsics, self.camera_height = intrinsics, camera_height
        self.known = np.zeros_like(truth)
        self._occupied = None
        self.fused = None
        self.tracker = tracker
        if mapping == "fused":
            from navbench.worldmodel.fusion import FusedMap

            # with a tracker, its own map (it fuses each frame at its estimate)
            self.fused = FusedMap.empty(full.spec) if tracker is None else tracker.fused
            self.rays = np.zeros_like(truth)

    def update(self, pose, frame: Frame) -> None:
        if self.fused is None:
            reveal_frame(self.known, self.xs, self.ys, pose, frame, self.intrinsics)
            return
        reveal_frame(self.rays, self.xs, self.ys, pose, frame, self.intrinsics, behind=0.0)
        if self.tracker is None:
            self.fused.fuse(frame, pose, self.intrinsics, self.camera_height)
        self._occupied = None  # seen_slice on demand

    def _slice(self) -> None:
        from navbench.worldmodel.fusion import seen_slice

        known, self._occupied = seen_slice(self.fused)
        self.known[...] = known | self.rays

    @property
    def occupied(self) -> np.ndarray:
        if self.fused is None:
            return self.truth & self.known
        if self._occupied is None:
            self._slice()
        return self._occupied

    def current_known(self) -> np.ndarray:
        if self.fused is not None and self._occupied is None:
            self._slice()
        return self.known

    def model(self) -> SeenMap:
        known = self.current_known()
        return SeenMap(self.full if self.fused is None else self.fused.vmap, known)


def _worth_a_look(match, rejected, cfg: ImageNavConfig) -> bool:
    """Go to a matched place (``"matched"``), or inspect a weak match of confidence at least
    ``inspect_confidence`` that is not within ``distinct_radius`` of a place inspected before."""
    if match.pose is None or match.status == "ambiguous":
        return False
    if match.status == "matched":
        return True
    return match.confidence >= cfg.inspect_confidence and not any(
        math.dist(match.pose[:2], r) <= cfg.stop.distinct_radius for r in rejected)


def _goal_score(match, cfg: ImageNavConfig):
    if match is None or match.pose is None or match.confidence < cfg.goal_min_confidence:
        return None
    g, c, s2 = match.pose[:2].copy(), float(match.confidence), 2.0 * cfg.goal_sigma ** 2
    return lambda p: c * np.exp(-np.sum((np.asarray(p) - g) ** 2, axis=1) / s2)


def loop_localizer_config(cfg: "ImageNavConfig"):
    """The :class:`~navbench.localize.LocalizerConfig` the loop matches the goal with on the seen
    map: the localiser's defaults on the loop's ``lattice_step``, without the near-tie search
    (``close_margin = 0``: tuned on single views of whole maps, not measured on goal matching
    in a partly seen house; the unknown-house figures ran without it). The cell key holds all
    of it."""
    from navbench.localize import LocalizerConfig

    return LocalizerConfig(lattice_step=cfg.lattice_step, close_margin=0.0)


def run_unknown_image_episode(level, start, goal: Frame, config: ImageNavConfig = ImageNavConfig(),
                              intrinsics: Intrinsics = HALF_CAMERA, full_map=None,
                              oracle_target=None, simulator=None, mapping: str = "perfect",
                              tracker=None) -> ImageEpisode:
    """One episode from ``start (3,)`` to the place ``goal`` shows (module docstring).
    ``full_map``: the level voxelised (:func:`~navbench.worldmodel.grid.voxelize_level`), passed
    in to share it across episodes. ``oracle_target (2,)``: RNR-Map's "GT stopper" ablation
    (Table 4): the agent stops as soon as its true position is within ``success_radius`` of it
    (Euclidean; the paper's reads the geodesic distance), and never by its own decision.
    ``simulator``: a :class:`~navbench.sim.world.Simulator` of ``level`` rendering ``intrinsics``
    frames (its noise and seed; default noise ``none``, seed 0); the agent reads its TRUE pose.
    ``mapping``: ``perfect`` (the module docstring) or ``fused`` (the frames fused at the true
    pose into a TSDF map, :class:`_Mapper`: what the agent knows is what its camera measured).
    ``tracker``: tracking and mapping together (``mapping="fused"`` only): a
    :class:`~navbench.track.slam.OnlineMapping` (e.g. ``ours`` from
    :func:`~navbench.track.slam.online_estimator` on ``full_map``'s grid), reset at the true
    start pose; the agent then acts on its estimate, and each frame is fused at the estimate.
    The oracle stopper reads the true pose."""
    import time
    from dataclasses import replace

    from navbench.localize import LocalizationError, Localizer
    from navbench.sim.dynamics import Control, clip_control
    from navbench.sim.world import Simulator
    from navbench.worldmodel.grid import voxelize_level

    cfg = config
    full = full_map if full_map is not None else voxelize_level(level)
    truth, xs, ys = full.occupancy_slice("band")
    sim = simulator if simulator is not None else Simulator(level, "none", 0, intrinsics)
    mapper = _Mapper(mapping, full, truth, xs, ys, intrinsics, sim.camera_height, tracker)
    known = mapper.known  # updated in place
    ecfg = cfg.explorer if cfg.exploration_score else replace(cfg.explorer, explore_weight=0.0, near_weight=0.0)
    explorer = Explorer(ecfg)
    stopper = GoalStopper(goal, cfg.stop)
    loc_cfg = loop_localizer_config(cfg)
    frame = sim.reset(np.asarray(start, np.float64))
    pose = np.asarray(sim.pose, np.float64).copy()
    if tracker is not None:
        tracker.reset(pose, frame)
    mapper.update(pose, frame)
    poses = [pose.copy()]
    beliefs = [pose.copy()]
    waypoints, target = None, None
    mode, place = "explore", None  # "explore" | "approach" (path to place) | "face" (turn to its heading)
    match, matches, approaches, rematch, last_match = None, 0, 0, True, 0
    rejected: list[np.ndarray] = []
    end, stop_step = "step-limit", -1
    guard, log = 0, []
    controls: list[tuple[float, float, float]] = []
    ms: dict[str, list[float]] = {"sim": [], "estimate": [], "plan": []}
    clock = [time.perf_counter()]  # end of the last step: what the agent computed since is "plan"

    def execute(control) -> bool:
        nonlocal pose
        t0 = time.perf_counter()
        res = sim.step(control)
        t1 = time.perf_counter()
        poses.append(np.asarray(res.pose, np.float64).copy())
        pose = (poses[-1].copy() if tracker is None
                else checked_pose(tracker, tracker.update(control, res.frame), len(controls) + 1))
        beliefs.append(pose.copy())
        controls.append((float(control.turn), float(control.direction), float(control.speed)))
        mapper.update(pose, res.frame)
        t2 = time.perf_counter()
        ms["plan"].append((t0 - clock[0]) * 1e3)
        ms["sim"].append((t1 - t0) * 1e3)
        ms["estimate"].append((t2 - t1) * 1e3)
        clock[0] = t2
        return bool(res.collided)

    for _ in range(cfg.look_around):  # turn in place once around: the camera sees 94 degrees
        execute(Control(math.radians(360.0 / max(cfg.look_around, 1)), float(pose[2]), 0.0))

    def step(control) -> bool:
        return execute(clip_control(control, pose[2]))

    while len(poses) - 1 < cfg.max_steps and guard < 4 * cfg.max_steps:
        guard += 1
        steps = len(poses) - 1
        if oracle_target is not None and math.dist(poses[-1][:2], np.asarray(oracle_target)[:2]) <= cfg.success_radius:
            end, stop_step = "stopped", steps
            break
        if rematch or (mode == "explore" and steps - last_match >= cfg.match_every):
            rematch, last_match = False, steps
            d = None
            try:
                loc = Localizer.build(mapper.model(), intrinsics, sim.camera_height, loc_cfg)
                d = stopper.update(loc, pose)
            except LocalizationError:
                pass
            if d is not None:
                match = d.match
                matches += 1
                log.append((steps, d.reason, round(match.confidence, 3), round(match.rival, 3), round(d.distance, 2)))
                if d.stop and oracle_target is None:
                    end, stop_step = "stopped", steps
                    break
                if d.reason == "confirming":  # at the place, matched once: turn one step, match again
                    rematch = True
                    if step(Control(cfg.controller.max_turn, float(pose[2]), 0.0)):
                        end = "stuck"
                        break
                    continue
            if mode == "face" and place is not None:  # inspected and not stopped: reject the place
                rejected.append(place[:2].copy())
                mode, waypoints = "explore", None
            if d is not None and _worth_a_look(d.match, rejected, cfg) and approaches < cfg.max_approaches:
                plan = plan_path(~seen_free(mapper.current_known(), mapper.occupied), xs, ys, pose[:2], d.match.pose[:2],
                                 ecfg.planner)
                if plan.ok:
                    mode, place, waypoints, approaches = "approach", d.match.pose.copy(), plan.waypoints, approaches + 1
        if mode == "face":
            err = float(wrap_angle(place[2] - pose[2]))
            if abs(err) <= cfg.controller.heading_threshold:
                rematch = True
                continue
            turn = max(-cfg.controller.max_turn, min(cfg.controller.max_turn, err))
            if step(Control(turn, float(pose[2]), 0.0)):
                end = "stuck"
                break
            continue
        if waypoints is None or len(waypoints) == 0:
            if mode == "approach":  # arrived at the place: face its heading, then match again
                mode, waypoints = "face", None
                continue
            gs = _goal_score(match, cfg) if cfg.goal_score else None
            dec = explorer.decide(mapper.current_known(), mapper.occupied, xs, ys, pose[:2], gs)
            if dec.status == "done":
                end = "explored"
                break
            waypoints, target = dec.plan.waypoints, dec.target
        control, waypoints = controller_step(pose, waypoints, cfg.controller)
        if control is None:
            if mode == "explore":
                explorer.reached(target)
            continue
        if step(control):
            end = "stuck"
            break
    known = mapper.current_known()
    free = ~truth
    return ImageEpisode(np.asarray(poses), end, matches, stop_step,
                        float((known & free).sum() / max(int(free.sum()), 1)), known,
                        None if match is None or match.pose is None else match.pose.copy(), log,
                        np.asarray(controls, np.float64).reshape(-1, 3),
                        {k: np.asarray(v, np.float64) for k, v in ms.items()},
                        "none" if match is None else str(match.status),
                        float("nan") if match is None else float(match.confidence),
                        None if tracker is None else np.asarray(beliefs))


def score_image_episode(ep: ImageEpisode, target_xy, optimal_length: float,
                        success_radius: float = 1.0) -> tuple[bool, float, float]:
    """``(success, spl_term, final distance m)`` under the ``nrns`` rule: stopped by the agent's
    own decision within ``success_radius`` m (Euclidean) of ``target_xy``; SPL term
    ``S * l / max(l, p)`` (Anderson et al. 2018) with ``p`` the true path length."""
    final = float(np.hypot(*(ep.true_poses[-1, :2] - np.asarray(target_xy, np.float64)[:2])))
    ok = ep.end_reason == "stopped" and final <= success_radius
    p = float(np.sum(np.hypot(*np.diff(ep.true_poses[:, :2], axis=0).T))) if len(ep.true_poses) > 1 else 0.0
    spl = float(optimal_length / max(optimal_length, p)) if ok else 0.0
    return ok, spl, final
