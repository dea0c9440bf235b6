"""``run-navigation --goal image --map online``: the unknown-house image-goal loop in the pipeline
(issue 15 §3 and §5).

Per task of the level's task set, the agent starts with no map and runs
:func:`navbench.nav.imagenav.run_unknown_image_episode`: it looks around, explores, matches the
goal image (:func:`navbench.nav.imagegoal.render_goal`, heading :func:`~navbench.nav.imagegoal.goal_heading`,
as the known-map path) against the map seen so far and stops by its own decision. Each episode is
one ``episodes`` row, stored, keyed and resumed like every other (the navigation stage): the cell
key adds ``{"online": ...}`` (the sensing model and the loop's full :class:`ImageNavConfig`), so
no key of another map mode changes and no online row shares a cell or a setup with them.

The sensing and pose model is explicit (:class:`OnlineConfig`), part of the key and of the
``conditions`` label :mod:`navbench.results.score` groups by (:func:`online_label`):

* ``mapping = "perfect"``: what the agent knows of a cell it has seen is the truth (the level's
  ``true-map`` artifact, the voxelized true geometry); only coverage is earned
  (:func:`~navbench.nav.imagenav.reveal_frame`). No fusion error, no depth noise.
* ``mapping = "fused"`` (``--map online-fused``): every frame is fused at the agent's pose into
  a TSDF voxel map (:class:`~navbench.worldmodel.fusion.FusedMap`, default settings); the agent
  plans, explores and matches the goal on what its depth camera measured
  (:func:`~navbench.worldmodel.fusion.seen_slice`), never on the truth.
* the pose is the estimator's (:data:`ONLINE_ESTIMATORS`): ``gt`` reads the simulator's true
  pose (the profile's noise still perturbs the executed motion); ``ours`` (``online-fused``
  only) tracks against the map it builds and the frames are fused at its estimate
  (:class:`~navbench.track.slam.OnlineMapping`: tracking and mapping together, no true pose
  after the start). The label says ``pose=true`` for a ``gt``-only run, else ``pose=estimator``.

The episode is stored as an :class:`OnlineEpisodeRecord` (an
:class:`~navbench.nav.episode.EpisodeRecord` plus the goal match and the seen cells); its
``end_reason`` is ``"reached"`` when the agent stopped (the STOP action the ``nrns`` and
``habitat`` presets need), else the loop's (``"step-limit"``, ``"stuck"``, ``"explored"``: the
house was seen and the goal never matched). ``success`` / ``spl_term`` stored are the ``paper``
rule's, as for every row; ``score --preset nrns`` (this mode's default) rescores them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from navbench.errors import ConfigError
# the results side labels and scores these runs; the names live there (re-exported here)
from navbench.results.labels import ONLINE_MAPS, ONLINE_PRESET, online_label  # noqa: F401

MAPPINGS = ("perfect", "fused")
#: The estimators (the pose model) each mapping accepts: ``gt`` the true pose, ``ours`` tracked.
ONLINE_ESTIMATORS = {"perfect": ("gt",), "fused": ("gt", "ours")}
#: The default estimator of the online map modes (the true pose).
ONLINE_ESTIMATOR = "gt"
#: Bumped when the loop gives other episodes for the same settings (part of the cell key).
LOOP_VERSION = 1
#: RNR-Map's Table 4 rows in navbench's terms (``--online-ablation``): the full model,
#: exploration without goal scoring, goal scoring without exploration, and the full model
#: stopped by an oracle once its true position is within the success radius of the goal; and one
#: variant: the full model with RNR-Map's exploration candidates (places on a Voronoi graph of the
#: seen free space) instead of navbench's frontiers (:mod:`navbench.plan.explore`).
ABLATIONS = ("full", "no-goal", "no-explore", "gt-stopper", "voronoi")
#: The :class:`~navbench.nav.imagenav.ImageNavConfig` fields each ablation sets.
_ABLATION_LOOP = {"full": {}, "no-goal": {"goal_score": False}, "no-explore": {"exploration_score": False},
                  "gt-stopper": {}, "voronoi": {}}
#: The :class:`~navbench.plan.explore.ExplorerConfig` fields each ablation sets.
_ABLATION_EXPLORER = {"voronoi": {"candidates": "voronoi"}}


@dataclass(frozen=True)
class OnlineConfig:
    """The unknown-house loop's sensing model: ``mapping`` (``perfect``: a seen cell reads the
    true geometry; ``fused``: the frames fused into a TSDF map); the pose model is the cell's
    estimator. See the module docstring."""

    mapping: str = "perfect"
    ablation: str = "full"  # ABLATIONS; "full" is left out of the key (keys of earlier runs hold)

    def __post_init__(self):
        if self.mapping not in MAPPINGS:
            raise ConfigError(f"online mapping: unknown {self.mapping!r}; choose one of {list(MAPPINGS)}")
        if self.ablation not in ABLATIONS:
            raise ConfigError(f"--online-ablation: unknown {self.ablation!r}; choose one of {list(ABLATIONS)}")


def is_online(map_source: str) -> bool:
    """Whether ``--map`` selects the unknown-house loop."""
    return map_source in ONLINE_MAPS


def online_config(map_source: str, ablation: str = "full") -> OnlineConfig | None:
    """The :class:`OnlineConfig` of a ``--map`` value and an ``--online-ablation`` (``None``: not
    an online map)."""
    return OnlineConfig(mapping=ONLINE_MAPS[map_source], ablation=ablation) if is_online(map_source) else None


def online_profile(profile, log=None):
    """``profile`` checked for ``--map online`` (unchanged for any other map): the goal must be
    an image and the estimators among :data:`ONLINE_ESTIMATORS` of its mapping (:class:`ConfigError`
    naming the option otherwise); the
    default ``paper`` preset becomes :data:`ONLINE_PRESET` (logged)."""
    import dataclasses

    if not is_online(profile.map_source):
        if getattr(profile, "online_ablation", "full") != "full":
            raise ConfigError(f"--online-ablation {profile.online_ablation}: an ablation of the unknown-house "
                              f"loop; use it with --map online or online-fused (got --map {profile.map_source})")
        return profile
    m = profile.map_source
    if profile.goal != "image":
        raise ConfigError(f"--map {m}: the unknown-house loop navigates to an image goal; use --goal image "
                          f"(got --goal {profile.goal}; a point goal in an unknown house is not implemented)")
    allowed = ONLINE_ESTIMATORS[ONLINE_MAPS[m]]
    if not set(profile.estimators) <= set(allowed):
        what = ("reads the true pose (estimator gt; tracking needs --map online-fused)" if allowed == ("gt",)
                else "reads the true pose (gt) or tracks on the map it builds (ours)")
        raise ConfigError(f"--map {m}: the unknown-house loop {what}; use --estimators "
                          f"{','.join(allowed)} or a part of it (got {','.join(profile.estimators)})")
    if profile.scoring_preset == "paper":
        if log is not None:
            log(f"--map {m}: scoring preset {ONLINE_PRESET} (the agent stops on its own; "
                "'paper' needs no stop)")
        profile = dataclasses.replace(profile, scoring_preset=ONLINE_PRESET)
    return profile


def loop_config(episode_overrides: dict, ablation: str = "full"):
    """The loop's :class:`~navbench.nav.imagenav.ImageNavConfig`: its defaults with the episode
    config's ``max_steps`` (500 unless ``[navigation.episode] max_steps`` says otherwise) and the
    fields the ``ablation`` (:data:`ABLATIONS`) switches off."""
    from navbench.nav.episode import EpisodeConfig
    from navbench.nav.imagenav import ImageNavConfig

    fields = dict(_ABLATION_LOOP[ablation])
    if ablation in _ABLATION_EXPLORER:
        from navbench.plan.explore import ExplorerConfig

        fields["explorer"] = ExplorerConfig(**_ABLATION_EXPLORER[ablation])
    return ImageNavConfig(max_steps=int(dict(episode_overrides).get("max_steps", EpisodeConfig().max_steps)),
                          **fields)


def online_key_part(cfg) -> dict:
    """What the unknown-house loop adds to the cell and condition keys of a
    :class:`~navbench.pipeline.stages.grid.NavigationConfig`: nothing unless ``cfg.online``."""
    from navbench.config import to_jsonable

    if getattr(cfg, "online", None) is None:
        return {}
    own = to_jsonable(cfg.online)
    if own.get("ablation") == "full":  # the full model: the keys of the runs before ablations
        own.pop("ablation")
    from navbench.localize.localizer import keyed_settings
    from navbench.nav.imagenav import loop_localizer_config

    loop = loop_config(cfg.episode, cfg.online.ablation)
    part = {**own, "loop": to_jsonable(loop), "version": LOOP_VERSION,
            # every field of the localiser the loop matches the goal with: its defaults change as
            # the localiser improves, and the episodes with them (keyed since 2026-11-26)
            "localizer": to_jsonable(keyed_settings(loop_localizer_config(loop)))}
    if cfg.online.mapping == "fused":  # the fusion's settings and version (its grids change with them)
        from navbench.worldmodel.fusion import FUSION_VERSION, FusionConfig

        part["fusion"] = {**to_jsonable(FusionConfig()), "version": FUSION_VERSION}
    return {"online": part}


def run_online_episode(level, full_map, task, simulator, intrinsics, cfg: OnlineConfig, loop,
                       goal_seed: int, noise: str, seed: int, estimator: str = ONLINE_ESTIMATOR,
                       estimator_seed: int = 0, options: dict | None = None):
    """One unknown-house episode of ``task`` (module docstring) in ``simulator`` (built for
    ``level`` rendering ``intrinsics``); ``full_map`` the true-map world model the perfect
    sensor reads (and whose grid the fused map uses); ``loop`` the
    :class:`~navbench.nav.imagenav.ImageNavConfig`; ``estimator`` the pose model (``gt`` or,
    fused only, a tracker built with ``estimator_seed`` and its ``options``). Returns an
    :class:`~navbench.nav.imagenav.OnlineEpisodeRecord`."""
    import numpy as np

    from navbench.nav.imagegoal import goal_heading, render_goal
    from navbench.nav.imagenav import OnlineEpisodeRecord, run_unknown_image_episode

    if estimator not in ONLINE_ESTIMATORS[cfg.mapping]:
        raise ConfigError(f"online mapping {cfg.mapping}: estimator {estimator!r} not accepted; "
                          f"choose from {list(ONLINE_ESTIMATORS[cfg.mapping])}")
    tracker = None
    if estimator != "gt":
        from navbench.track.slam import online_estimator
        from navbench.worldmodel.fusion import FusedMap

        tracker = online_estimator(estimator, FusedMap.empty(full_map.spec), intrinsics, simulator.camera_height,
                                   seed=estimator_seed, **(options or {}))
    goal = render_goal(level, task, intrinsics, goal_seed)
    oracle = np.asarray(task.target, np.float64)[:2] if cfg.ablation == "gt-stopper" else None
    ep = run_unknown_image_episode(level, np.asarray(task.start, np.float64), goal, loop, intrinsics,
                                   full_map, oracle_target=oracle, simulator=simulator, mapping=cfg.mapping,
                                   tracker=tracker)
    collided = ep.end_reason == "stuck"
    err = float("nan") if ep.goal_pose is None else float(math.dist(ep.goal_pose[:2], task.target[:2]))
    return OnlineEpisodeRecord(
        level=level.name, task_id=int(task.id), estimator=estimator, noise=noise, seed=int(seed),
        start=np.asarray(task.start, np.float64), target=np.asarray(task.target, np.float64),
        optimal_length=float(task.optimal_length), true_poses=ep.true_poses,
        est_poses=(ep.true_poses if ep.est_poses is None else ep.est_poses).copy(),
        controls=ep.controls, collided=collided, collision_step=len(ep.controls) - 1 if collided else -1,
        plan=np.zeros((0, 2)), replans=0, end_reason="reached" if ep.end_reason == "stopped" else ep.end_reason,
        timings_ms=ep.timings_ms, plan_status="explore", goal_status=ep.goal_status,
        goal_confidence=ep.goal_confidence, goal_err_m=err, goal_heading=goal_heading(goal_seed, task.id),
        matches=int(ep.matches), seen_share=float(ep.seen_share), known=np.asarray(ep.known, bool))


def online_row_fields(record) -> dict:
    """The goal columns of an online episode's ``episodes`` row (``{}`` for another record)."""
    if not hasattr(record, "goal_status"):  # an OnlineEpisodeRecord (imported lazily: numba)
        return {}

    def num(x):
        return None if x is None or x != x else float(x)

    return {"goal": "image", "goal_status": f"online-{record.goal_status}",
            "goal_err_m": num(record.goal_err_m), "goal_confidence": num(record.goal_confidence),
            "goal_heading": num(record.goal_heading)}
