"""image-goals: every task's goal image localised in the agent's map (issue 15 §2, known map).

Per level, for each task of the task set: render the goal image (:func:`navbench.nav.imagegoal.render_goal`,
the true level seen from the target with the seeded heading), localise it in the map the agent
plans on with the localiser of :func:`navbench.pipeline.stages.localize.load_localizer` (its
signature bank cached as ``localize-bank``), and classify the result
(:func:`navbench.nav.imagegoal.classify`). The artifact ``goals.json`` maps each task id to the
goal heading, the found pose (the target the agent plans to), the confidence, the status and the
error against the true target. It is keyed by the level, map and task-set keys and the
:class:`ImageGoalConfig`. Localisation depends on neither estimator nor noise, so it runs once
per task, not once per episode; workers read the found targets from the artifact.

Simulator (issue 37): on ``vizdoom`` the goal image is the engine's frame at the goal pose
(:class:`~navbench.sim.backends.PoseRenderer`; the engine places it to the whole centimetre and
1/65536 turn), localised with the engine's projection, as the agent's own frames are; the
simulator joins the key only when it is not pymunk (:func:`image_goals_key_config`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from navbench.errors import ConfigError
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.level import load_level_ref

GOALS_FILE = "goals.json"
GOAL_KINDS = ("point", "image")


@dataclass(frozen=True)
class ImageGoalConfig:
    """Image goals: ``seed`` of the goal headings, the ``camera`` preset of the goal image (the
    simulator's), the status rules (:class:`navbench.nav.imagegoal.GoalRules`, fields as
    there) and ``localizer`` overrides of :class:`navbench.localize.LocalizerConfig` fields."""

    seed: int = 0
    camera: str = "half"
    min_confidence: float = 0.8
    ambiguity_radius: float = 1.0
    ambiguity_margin: float = 0.02
    localizer: dict = field(default_factory=dict)

    def localizer_config(self):
        import dataclasses

        from navbench.localize import LocalizerConfig

        names = {f.name for f in dataclasses.fields(LocalizerConfig)}
        bad = sorted(set(self.localizer) - names)
        if bad:
            raise ConfigError(f"image goals: unknown localizer field(s) {bad}; known: {sorted(names)}")
        return dataclasses.replace(LocalizerConfig(), k=2, **self.localizer)

    def localizer_settings(self) -> dict:
        """Every field of :meth:`localizer_config` as plain JSON: what the goals' keys hold of
        the localiser (its defaults change as it improves, and the goals found with them)."""
        from navbench.config import to_jsonable
        from navbench.localize.localizer import keyed_settings

        return to_jsonable(keyed_settings(self.localizer_config()))

    def rules(self):
        from navbench.nav.imagegoal import GoalRules

        return GoalRules(self.min_confidence, self.ambiguity_radius, self.ambiguity_margin)


class _MapHandle:
    """The map a localiser bank is built for (``key``, ``load()``), as ``load_localizer`` wants."""

    def __init__(self, ref: Ref):
        self.key, self._path = ref.key, ref.path

    def load(self):
        from navbench.worldmodel.base import load_world_model

        return load_world_model(self._path)


def image_goals_key_config(cfg: ImageGoalConfig, sim: str = "pymunk") -> dict:
    """What the image-goals key hashes: ``cfg``'s fields, plus the simulator when it is not the
    reference one (:func:`navbench.benchmark.sim_key_part`; a pymunk key is the one stored before)."""
    from navbench.benchmark import sim_key_part
    from navbench.config import to_jsonable

    return {**to_jsonable(cfg), **sim_key_part(sim)}


def image_goals_stage(ctx: StageContext, level: Ref, vmap: Ref, tasks: Ref, cfg: ImageGoalConfig,
                      sim: str = "pymunk") -> Ref:
    """Localise every task's goal image of ``tasks`` in ``vmap`` (see the module docstring),
    the images rendered by simulator ``sim``; the artifact ``goals.json``."""

    def compute(d: Path) -> None:
        from navbench.geometry import CAMERA_HEIGHT, camera_by_name
        from navbench.pipeline.stages.localize import load_localizer, localize_bank_stage
        from navbench.plan.tasks import load_tasks
        from navbench.sim.backends import sim_intrinsics

        intr = sim_intrinsics(sim, camera_by_name(cfg.camera))  # the engine's projection on vizdoom
        task_list = load_tasks(tasks.path)
        update = ctx.progress(f"image goals {level.name}", len(task_list))
        out = {}
        workers = min(int(ctx.workers), len(task_list))
        if workers > 1:  # the same goals: each task's localisation depends on nothing else
            from navbench.pipeline.executor import LocalExecutor

            # the bank is cached here; each worker builds its own localiser from it
            bank = localize_bank_stage(ctx, _MapHandle(vmap), CAMERA_HEIGHT, cfg.localizer_config(), level)
            size = max(1, min(8, len(task_list) // (4 * workers)))
            specs = [(level.path, level.name, vmap.path, bank.path, cfg, task_list[i:i + size], sim)
                     for i in range(0, len(task_list), size)]
            with LocalExecutor(workers) as ex:
                for part in ex.map_unordered(localize_goals, specs):
                    out.update(part)
                    update(len(out))
        else:
            localizer, _ = load_localizer(ctx, _MapHandle(vmap), intr, CAMERA_HEIGHT, cfg.localizer_config(),
                                          level=level)
            lv = load_level_ref(level)
            with GoalCamera(sim, lv, cfg.camera) as camera:
                for i, t in enumerate(task_list):
                    out.update(_localize_goal(localizer, camera, cfg, t))
                    update(i + 1)
        (d / GOALS_FILE).write_text(json.dumps(out, indent=1, sort_keys=True))

    from navbench.config import config_hash

    inputs = {"level": level.key, "map": vmap.key, "tasks": tasks.key,
              "localizer": config_hash(cfg.localizer_settings())}  # the resolved localiser, since 2026-11-26
    path, key, cached = ctx.run("image-goals", image_goals_key_config(cfg, sim), inputs, compute)
    return Ref("image-goals", key, path / GOALS_FILE, cached, level.name)


class GoalCamera:
    """The goal images of ``level`` from simulator ``sim`` with camera preset ``camera``:
    ``render(task, seed) -> Frame``. On pymunk :func:`navbench.nav.imagegoal.render_goal` itself
    (the bytes stored before the choice); on vizdoom the engine's frame at
    :func:`~navbench.nav.imagegoal.goal_pose` (an engine process: use as a context manager)."""

    def __init__(self, sim: str, level, camera: str):
        from navbench.geometry import CAMERA_HEIGHT, camera_by_name
        from navbench.sim.backends import PoseRenderer

        self.level, self._base = level, camera_by_name(camera)
        self._engine = None if sim == "pymunk" else PoseRenderer(sim, level, self._base, CAMERA_HEIGHT)

    def render(self, task, seed: int):
        from navbench.nav.imagegoal import goal_pose, render_goal

        if self._engine is None:
            return render_goal(self.level, task, self._base, seed)
        return self._engine.render(goal_pose(task, seed))

    def close(self) -> None:
        if self._engine is not None:
            self._engine.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _localize_goal(localizer, camera: GoalCamera, cfg: ImageGoalConfig, task) -> dict:
    """``{task id: goal record}`` of one task: its goal image rendered and localised."""
    from navbench.nav.imagegoal import classify, goal_heading

    frame = camera.render(task, cfg.seed)
    loc = classify(localizer.localize(frame, k=2), task.target, cfg.rules())
    return {str(task.id): {"heading": goal_heading(cfg.seed, task.id), "pose": loc.pose,
                           "status": loc.status, "confidence": _num(loc.confidence),
                           "error_m": _num(loc.error_m),
                           "ms": float(localizer.last_timing.get("total", 0.0))}}


#: A pool worker's localiser, level and intrinsics, kept between chunks (one entry: the latest).
_WORKER_STATE: dict = {}


def localize_goals(spec) -> dict:
    """Pool worker: the goal records of a chunk ``(level path, level name, map path, bank path,
    config, tasks, simulator)``, with the localiser built once per process from the cached map
    and bank (an engine, vizdoom, runs for the chunk only: no process outlives it)."""
    from navbench.config import config_hash
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.levelio import load_level
    from navbench.pipeline.stages.localize import localizer_from_bank
    from navbench.sim.backends import sim_intrinsics
    from navbench.worldmodel.base import load_world_model

    level_path, level_name, map_path, bank_path, cfg, chunk, sim = spec
    key = (str(level_path), str(map_path), str(bank_path), config_hash(cfg), sim)
    if key not in _WORKER_STATE:
        _WORKER_STATE.clear()
        intr = sim_intrinsics(sim, camera_by_name(cfg.camera))
        localizer = localizer_from_bank(bank_path, load_world_model(map_path), intr, CAMERA_HEIGHT,
                                        cfg.localizer_config())
        _WORKER_STATE[key] = (localizer, load_level(level_path, name=level_name or None))
    localizer, level = _WORKER_STATE[key]
    out = {}
    with GoalCamera(sim, level, cfg.camera) as camera:
        for t in chunk:
            out.update(_localize_goal(localizer, camera, cfg, t))
    return out


def _num(x: float) -> float | None:
    return None if x != x else float(x)


def load_goals(path) -> dict[int, dict]:
    """``{task id: goal record}`` of a ``goals.json`` artifact."""
    return {int(k): v for k, v in json.loads(Path(path).read_text()).items()}


def goal_row_fields(goal: dict | None) -> dict:
    """The ``episodes`` columns of an image-goal episode (``{}`` for a point goal)."""
    if goal is None:
        return {}
    return {"goal": "image", "goal_status": goal["status"], "goal_err_m": goal["error_m"],
            "goal_confidence": goal["confidence"], "goal_heading": goal["heading"]}
