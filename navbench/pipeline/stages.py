"""The pipeline's stages: one frozen config dataclass and one function per stage.

make-level -> collect-views -> fit-map -> sample-tasks -> run-navigation -> score -> report

Every stage function takes a :class:`StageContext` (the artifact store, the results database, a
log and progress callbacks, the ``force`` set), its config and the references of its inputs, and
returns a reference (stage, key, path) to its verified artifact. Keys are computed before any
work (:func:`navbench.pipeline.cache.run_stage`), so a cached stage costs one checksum pass.
Stages never build SQL or ad-hoc paths: artifacts live in the store, rows go through
:class:`navbench.pipeline.db.ResultsDB`. Heavy work and torch are imported inside the compute
functions only: a fully cached pipeline never loads torch (resolving the FitConfig defaults for
the fit-map key imports the world-model module, which brings numba) and takes about a second.

Keys of committed, human-readable inputs are content hashes: a level's key is the sha256 of its
``levels/NAME.json`` text, a task set's key the sha256 of its task file text (whether the file
is committed under ``tasks/`` or sampled into the cache), so generating a file and committing it
leaves every downstream key unchanged.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from navbench.config import config_hash, to_jsonable
from navbench.errors import ArtifactError, ConfigError
from navbench.pipeline.cache import ArtifactStore, run_stage

#: Artifact format versions: bump one to invalidate that stage's cache.
FORMAT = {"make-level": 1, "collect-views": 1, "fit-map": 1, "true-map": 1, "sample-tasks": 1,
          "episode": 1, "score": 1, "report": 2, "verify": 1}
#: Estimators that never look at camera frames: their simulator skips rendering.
FRAMELESS_ESTIMATORS = frozenset({"gt", "dynamics"})


def _noop(*_a, **_k) -> None:
    pass


@dataclass
class StageContext:
    """What every stage needs besides its config.

    ``force``: stage names to recompute even when cached (``{"*"}`` = all).
    ``progress(description, total) -> update``: a progress-bar factory (no-op by default);
    ``update(done, total=None, loss=None)`` sets the bar to ``done`` items (``loss``: shown
    for fits). It matches the ``progress`` callbacks of ``collect_views`` and ``fit_map``.
    ``levels_dir`` / ``tasks_dir``: where committed level and task files are looked up.
    """

    store: ArtifactStore
    db: Any = None
    log: Callable[[str], None] = _noop
    progress: Callable[[str, int], Callable[[int], None]] = lambda desc, total: _noop
    force: frozenset = frozenset()
    levels_dir: Path = Path("levels")
    tasks_dir: Path = Path("tasks")
    used: list = field(default_factory=list)   # (stage, key) pairs touched: gc roots

    def forced(self, stage: str) -> bool:
        return "*" in self.force or stage in self.force

    def run(self, stage: str, config: Any, inputs: dict[str, str],
            compute: Callable[[Path], None]) -> tuple[Path, str, bool]:
        path, key, cached = run_stage(self.store, stage, config, inputs, FORMAT[stage], compute,
                                      force=self.forced(stage), log=self.log)
        self.used.append((stage, key))
        return path, key, cached


@dataclass(frozen=True)
class Ref:
    """A verified artifact: ``stage``, ``key`` (sha256 hex), ``path`` (a file or directory)."""

    stage: str
    key: str
    path: Path
    cached: bool = True
    name: str = ""          # level name for per-level artifacts
    meta: dict = field(default_factory=dict, compare=False)


def _sha256_text(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


VERIFY_FILE = "verified.json"


def verified(ctx: StageContext, what: str, inputs: dict[str, str], check: Callable[[], None]) -> None:
    """Run ``check()`` (which raises on failure) once per content keys ``inputs``.

    A passed check is remembered as a tiny ``verify`` artifact keyed by ``what`` and ``inputs``,
    so a rerun on the same level and task files costs one lookup instead of the check (the
    task-set check recomputes 200 shortest paths: ~0.1 s warm, seconds with the planner's
    first compilation). A failed check stores nothing and its error propagates.
    """
    def compute(d: Path) -> None:
        check()
        (d / VERIFY_FILE).write_text(json.dumps({"verified": what, "inputs": inputs}, sort_keys=True))

    ctx.run("verify", {"check": what}, inputs, compute)


# ------------------------------------------------------------------------------ make-level

@dataclass(frozen=True)
class LevelConfig:
    """make-level: ``name`` of the level; ``seed`` of the level generator, used only when no
    ``levels/NAME.json`` is committed (benchmark levels use their own table seed)."""

    name: str
    seed: int = 1


def make_level_stage(ctx: StageContext, cfg: LevelConfig) -> Ref:
    """The level's file and content key: the committed ``levels/NAME.json`` if present, else a
    level generated by :mod:`navbench.levelgen` and cached (key of (name, seed, generator))."""
    from navbench.errors import LevelError
    from navbench.names import check_name

    check_name("level name", cfg.name, LevelError)
    committed = Path(ctx.levels_dir) / f"{cfg.name}.json"
    if committed.is_file():
        key = _sha256_text(committed)
        ctx.log(f"make-level: {cfg.name} from {committed} ({key[:12]})")

        def check() -> None:
            from navbench.levelio import read_level_file

            _, text = read_level_file(committed, name=cfg.name)  # fields, name, free space
            if hashlib.sha256(text.encode()).hexdigest() != key:
                raise LevelError(f"{committed}: changed while it was being read; run again")

        # a committed file is checked once per content (the free-space check needs scipy)
        verified(ctx, "level", {"level": key}, check)
        ref = Ref("make-level", key, committed, True, cfg.name, {"source": "committed"})
    else:
        def compute(d: Path) -> None:
            from navbench import levelgen
            from navbench.levelio import save_level

            if cfg.name in levelgen.BENCHMARK_LEVELS:
                level = levelgen.make_benchmark_level(cfg.name)
            else:
                level = levelgen.generate_level(cfg.name, cfg.seed)
            save_level(level, d / "level.json")

        from navbench import levelgen as _lg  # light: numpy only

        gen_cfg = {"level": to_jsonable(cfg), "generator": getattr(_lg, "GENERATOR_VERSION", 0)}
        origin = ("the benchmark's seed" if cfg.name in _lg.BENCHMARK_LEVELS
                  else f"seed {cfg.seed} (the profile's level_seed)")
        ctx.log(f"make-level: no {committed}; {cfg.name} is generated from {origin}")
        path, _, cached = ctx.run("make-level", gen_cfg, {}, compute)
        f = path / "level.json"
        key = _sha256_text(f)
        ref = Ref("make-level", key, f, cached, cfg.name, {"source": "generated"})
    if ctx.db is not None:
        ctx.db.record_level(cfg.name, ref.key, {"path": str(ref.path), **ref.meta})
    return ref


def load_level_ref(ref: Ref):
    """The :class:`navbench.level.Level` of a make-level reference."""
    from navbench.levelio import load_level

    return load_level(ref.path, name=ref.name or None)


# --------------------------------------------------------------------------- collect-views

@dataclass(frozen=True)
class ViewsConfig:
    """collect-views: ``count`` pose-labelled RGB-D views sampled uniformly in free space with
    ``camera`` (``half``: 160x120, ``paper``: 320x240) from pose sampling ``seed``."""

    count: int
    camera: str = "half"
    seed: int = 0

    def __post_init__(self):
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count < 1:
            raise ConfigError(f"view count must be a whole number >= 1, got {self.count!r}")
        if self.camera not in ("half", "paper"):
            raise ConfigError(f"unknown camera {self.camera!r}; choose half or paper")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ConfigError(f"views seed must be a whole number >= 0, got {self.seed!r}")

    def check_memory(self, what: str = "collect-views") -> None:
        """Refuse (ConfigError naming ``what``) a collection whose images do not fit in the
        available memory: :func:`navbench.worldmodel.views.check_views_memory`."""
        from navbench.geometry import camera_by_name
        from navbench.worldmodel.views import check_views_memory

        check_views_memory(self.count, camera_by_name(self.camera), what)


VIEWS_FILE = "views"   # a directory of .npy files (memory-mapped on load)


def collect_views_stage(ctx: StageContext, level: Ref, cfg: ViewsConfig) -> Ref:
    """Collect views of ``level`` into the cache (the ``views/`` directory of
    :func:`navbench.worldmodel.views.save_views`)."""

    def compute(d: Path) -> None:
        from navbench.geometry import camera_by_name
        from navbench.worldmodel.views import check_views_disk, collect_views, save_views

        # before any rendering: the memory the views need (collect_views checks it again for
        # library callers) and the disk space they are saved to
        cfg.check_memory(f"collect-views ({level.name})")
        check_views_disk(cfg.count, camera_by_name(cfg.camera), d, f"collect-views ({level.name})")
        update = ctx.progress(f"views {level.name} (seed {cfg.seed})", cfg.count)
        views = collect_views(load_level_ref(level), cfg.count, camera_by_name(cfg.camera), cfg.seed,
                              progress=update)
        save_views(views, d / VIEWS_FILE)

    path, key, cached = ctx.run("collect-views", cfg, {"level": level.key}, compute)
    return Ref("collect-views", key, path / VIEWS_FILE, cached, level.name)


# -------------------------------------------------------------------------------- fit-map

@dataclass(frozen=True)
class FitMapConfig:
    """fit-map: ``steps`` Adam steps from batch seed ``seed``; ``fit`` holds any other
    :class:`navbench.worldmodel.fit.FitConfig` field. The map is evaluated on held-out views
    (a separate collect-views with ``eval_count`` views from ``eval_seed``)."""

    steps: int = 200
    seed: int = 0
    fit: dict = field(default_factory=dict)
    eval_count: int = 200
    eval_seed: int = 1

    def fit_config(self):
        """The resolved :class:`FitConfig` (imports the world-model fit module)."""
        from navbench.worldmodel.fit import FitConfig

        names = {f.name for f in dataclasses.fields(FitConfig)}
        unknown = set(self.fit) - names
        if unknown:
            raise ConfigError(f"unknown FitConfig field(s) {sorted(unknown)}; known: {sorted(names)}")
        kw = dict(self.fit)
        kw.update(steps=self.steps, seed=self.seed)
        return FitConfig(**kw)


MAP_FILE = "map.npz"
METRICS_FILE = "metrics.json"
#: Fields the fit-map command's ``--json`` always prints.
MAP_METRIC_KEYS = ("depth_mae_m", "rgb_l1", "slice_precision", "slice_recall", "fit_seconds", "steps")


def fit_map_stage(ctx: StageContext, level: Ref, views: Ref, eval_views: Ref, cfg: FitMapConfig) -> Ref:
    """Fit a voxel map to ``views``, evaluate it on ``eval_views`` and the level's true slice;
    the artifact holds ``map.npz`` and ``metrics.json``. ``ref.meta`` is the metrics dict."""
    fit_cfg = cfg.fit_config()
    resolved = {"fit": to_jsonable(fit_cfg), "eval_count": cfg.eval_count}

    def compute(d: Path) -> None:
        from navbench.worldmodel.fit import evaluate_map, fit_map
        from navbench.worldmodel.grid import save_map
        from navbench.worldmodel.views import load_views

        train = load_views(views.path)
        update = ctx.progress(f"fit {level.name}", fit_cfg.steps)
        vmap, metrics = fit_map(train, fit_cfg, progress=update)
        del train
        held = load_views(eval_views.path)
        quality = evaluate_map(vmap, load_level_ref(level), held)
        out = {**dict(metrics), **dict(quality)}
        out.setdefault("fit_seconds", out.get("fit_time_s"))
        out.setdefault("steps", fit_cfg.steps)
        out["eval_views"] = int(cfg.eval_count)
        save_map(vmap, d / MAP_FILE)
        (d / METRICS_FILE).write_text(json.dumps(to_jsonable(out), indent=1, sort_keys=True))

    path, key, cached = ctx.run("fit-map", resolved,
                                {"level": level.key, "views": views.key, "eval_views": eval_views.key},
                                compute)
    metrics = json.loads((path / METRICS_FILE).read_text())
    if ctx.db is not None:
        ctx.db.record_map(level.name, key, metrics)
    return Ref("fit-map", key, path / MAP_FILE, cached, level.name, metrics)


@dataclass(frozen=True)
class TrueMapConfig:
    """true-map: the level's TRUE geometry voxelized (:func:`navbench.worldmodel.grid.voxelize_level`)
    with square cells of ``cell`` metres in x, y (the paper's grid: 11.4 m / 200) and ``nz``
    cells in z. An upper bound for planning, and a map for tests that need no fit."""

    cell: float = 11.4 / 200
    nz: int = 20


def true_map_stage(ctx: StageContext, level: Ref, cfg: TrueMapConfig = TrueMapConfig()) -> Ref:
    """The voxelized true geometry as a map artifact (``map.npz``, ``metrics.json``)."""

    def compute(d: Path) -> None:
        import math

        from navbench.worldmodel.grid import grid_for_level, save_map, voxelize_level

        lv = load_level_ref(level)
        shape = (max(2, math.ceil(lv.width / cfg.cell - 1e-9)), max(2, math.ceil(lv.depth / cfg.cell - 1e-9)), cfg.nz)
        save_map(voxelize_level(lv, grid_for_level(lv, shape=shape)), d / MAP_FILE)
        (d / METRICS_FILE).write_text(json.dumps({"source": "true", "steps": 0}))

    path, key, cached = ctx.run("true-map", cfg, {"level": level.key}, compute)
    metrics = json.loads((path / METRICS_FILE).read_text())
    if ctx.db is not None:
        ctx.db.record_map(level.name, key, metrics)
    return Ref("true-map", key, path / MAP_FILE, cached, level.name, metrics)


# --------------------------------------------------------------------------- sample-tasks

@dataclass(frozen=True)
class TasksConfig:
    """sample-tasks: ``count`` tasks sampled on the true geometry from ``seed``
    (constraints: :func:`navbench.plan.tasks.sample_tasks`)."""

    count: int = 30
    seed: int = 0

    def __post_init__(self):
        if self.count < 1:
            raise ConfigError(f"task count must be >= 1, got {self.count}")


TASKS_FILE = "tasks.json"


def committed_task_file(tasks_dir: Path, level: Ref, cfg: TasksConfig, prefix_ok: bool = False) -> Path | None:
    """A committed ``tasks/<level>-<count>-*.json`` whose level hash, seed and count match.

    With ``prefix_ok`` a file with MORE tasks also matches: :func:`~navbench.plan.tasks.sample_tasks`
    draws tasks one after the other from one seeded stream, so the first ``count`` tasks of a
    larger set of the same seed are exactly the ``count``-task set.
    """
    import re

    from navbench.plan.tasks import read_task_file
    from navbench.errors import TaskError

    # Every file named like one of this level's task files (``<level>-<count>-<hash8>.json``)
    # must read and say it is this level's: a malformed or mislabelled committed file is an
    # error, not silently skipped (the user would think it is used). Other files are not ours.
    own = re.compile(re.escape(level.name) + r"-[0-9]+-[0-9a-f]{8}\.json")
    best = None
    for p in sorted(Path(tasks_dir).glob(f"{level.name}-*.json")):
        if not own.fullmatch(p.name):
            continue
        ts = read_task_file(p)
        if ts.level != level.name:
            raise TaskError(f"{p}: level: says {ts.level!r} but the file name says {level.name!r}")
        if ts.level_sha256 != level.key or ts.seed != cfg.seed:
            continue  # another version of the level, or another seed
        if ts.count == cfg.count:
            return p
        if prefix_ok and ts.count > cfg.count and (best is None or ts.count < best[0]):
            best = (ts.count, p)
    return best[1] if best else None


def sample_tasks_stage(ctx: StageContext, level: Ref, cfg: TasksConfig) -> Ref:
    """The level's task set: a matching committed task file, else the first ``count`` tasks of a
    larger committed set of the same seed, else sampled; the last two are cached. The key is the
    sha256 of the task file text, so all three give the same key for the same tasks."""
    committed = committed_task_file(ctx.tasks_dir, level, cfg)
    if committed is not None:
        path, cached = committed, True
        ctx.log(f"sample-tasks: {level.name} from {committed}")
    else:
        def compute(d: Path) -> None:
            from navbench.plan.tasks import load_tasks, sample_tasks, save_tasks

            larger = committed_task_file(ctx.tasks_dir, level, cfg, prefix_ok=True)
            if larger is not None:
                ctx.log(f"sample-tasks: {level.name}: the first {cfg.count} tasks of {larger}")
                tasks = load_tasks(larger)[:cfg.count]
            else:
                tasks = sample_tasks(load_level_ref(level), cfg.count, cfg.seed)
            save_tasks(d / TASKS_FILE, level.name, tasks, level_hash=level.key, seed=cfg.seed)

        adir, _, cached = ctx.run("sample-tasks", cfg, {"level": level.key}, compute)
        path = adir / TASKS_FILE
    key = _sha256_text(path)

    def check() -> None:
        from navbench.errors import TaskError
        from navbench.plan.tasks import check_tasks_on_level, read_task_file

        ts = read_task_file(path)
        if ts.level != level.name or ts.level_sha256 != level.key:
            raise TaskError(f"{path}: level, level_sha256: the tasks are not for "
                            f"{level.name} {level.key[:12]}")
        check_tasks_on_level(load_level_ref(level), ts.tasks, str(path))

    # before any episode: every start and target free, every optimal_length exact
    verified(ctx, "tasks", {"level": level.key, "tasks": key}, check)
    if ctx.db is not None:
        from navbench.plan.tasks import load_tasks

        ctx.db.record_task_set(level.name, key, load_tasks(path))
    return Ref("sample-tasks", key, path, cached, level.name)


# ---------------------------------------------------------------------- level inputs bundle

@dataclass(frozen=True)
class LevelInputs:
    """Everything navigation needs for one level: the level, its map and its task set."""

    level: Ref
    map: Ref
    tasks: Ref


def build_level_inputs(ctx: StageContext, profile, level_name: str,
                       views_key: str | None = None) -> LevelInputs:
    """Run (or fetch from the cache) make-level -> collect-views (train and held-out) -> fit-map
    -> sample-tasks for one level with ``profile``'s settings. ``views_key`` replaces the
    training views by a stored collect-views artifact. With ``profile.map_source == "true"``
    the map is the voxelized true geometry and no views are collected."""
    level = make_level_stage(ctx, LevelConfig(level_name, profile.level_seed))
    if profile.map_source == "true":
        return LevelInputs(level, true_map_stage(ctx, level),
                           sample_tasks_stage(ctx, level, TasksConfig(profile.tasks, profile.tasks_seed)))
    vmap = fit_map_for_profile(ctx, profile, level, views_key)
    tasks = sample_tasks_stage(ctx, level, TasksConfig(profile.tasks, profile.tasks_seed))
    return LevelInputs(level, vmap, tasks)


def fit_map_for_profile(ctx: StageContext, profile, level: Ref, views_key: str | None = None) -> Ref:
    """collect-views (train and held-out) -> fit-map for one level with ``profile``'s settings."""
    cfg = FitMapConfig(profile.fit_steps, profile.fit_seed, dict(profile.fit), profile.eval_views,
                       profile.eval_seed)
    fit_cfg = cfg.fit_config()  # a bad fit option fails here, before any views are collected
    if fit_cfg.device.startswith("cuda"):  # an explicit GPU request (imports torch only then)
        from navbench.worldmodel.fit import resolve_fit_device

        resolve_fit_device(fit_cfg.device)
    camera = profile.camera
    if views_key:
        stage, key = ctx.store.find(views_key, "collect-views")
        p = ctx.store.load(stage, key)
        man = json.loads((p / "manifest.json").read_text())
        if man.get("inputs", {}).get("level") != level.key:
            raise ArtifactError(f"views {key[:12]} were not collected on level {level.name} "
                                f"(level key {level.key[:12]})")
        camera = man.get("config", {}).get("camera", camera)
        views = Ref(stage, key, p / VIEWS_FILE, True, level.name)
    else:
        views = collect_views_stage(ctx, level, ViewsConfig(profile.views, camera, profile.views_seed))
    held = collect_views_stage(ctx, level, ViewsConfig(profile.eval_views, camera, profile.eval_seed))
    return fit_map_stage(ctx, level, views, held, cfg)


# ------------------------------------------------------------------------- run-navigation

@dataclass(frozen=True)
class NavigationConfig:
    """run-navigation: the grid estimators x noise x tasks x ``seeds`` episode seeds per task.

    ``camera`` is the simulator's and estimators' camera; ``episode`` holds
    :class:`navbench.nav.episode.EpisodeConfig` fields; ``estimator_options`` maps an estimator
    name to its keyword arguments; ``slice_mode`` is the map's horizontal slice for planning.
    """

    estimators: tuple[str, ...] = ("ours", "no-map", "dynamics")
    noise: tuple[str, ...] = ("mid",)
    seeds: int = 1
    camera: str = "half"
    episode: dict = field(default_factory=dict)
    estimator_options: dict = field(default_factory=dict)
    slice_mode: str = "band"


@dataclass(frozen=True)
class Cell:
    """One cell of the grid: a level's inputs x estimator x noise. ``key`` is the cell key
    (config hash of level, map, task set, estimator, its options, noise, episode config)."""

    level: str
    level_key: str
    map_key: str
    tasks_key: str
    estimator: str
    options: dict
    noise: str
    episode: dict          # EpisodeConfig overrides (the key hashes the resolved config)
    key: str


@dataclass(frozen=True)
class EpisodeJob:
    """One episode to run: its cell, task id, episode seed and the derived RNG seeds."""

    cell: Cell
    task_id: int
    seed: int
    sim_seed: int
    estimator_seed: int


@dataclass(frozen=True)
class ChunkSpec:
    """A batch of episodes of ONE level for a worker (it loads the level, map and tasks once).
    Paths must be readable by the worker (a shared filesystem for Ray clusters)."""

    level_path: str
    map_path: str
    tasks_path: str
    camera: str
    slice_mode: str
    jobs: tuple[EpisodeJob, ...]


def build_episode_config(overrides: dict):
    """An :class:`navbench.nav.episode.EpisodeConfig` from field overrides; a dict value for a
    dataclass-valued field (``planner``, ``controller``) overrides that dataclass's fields."""
    from navbench.nav.episode import EpisodeConfig

    base = EpisodeConfig()
    kw = {}
    names = {f.name for f in dataclasses.fields(EpisodeConfig)}
    for k, v in dict(overrides).items():
        if k not in names:
            raise ConfigError(f"unknown episode config field {k!r}; known: {sorted(names)}")
        default = getattr(base, k)
        if dataclasses.is_dataclass(default) and isinstance(v, dict):
            try:
                v = dataclasses.replace(default, **v)
            except TypeError as e:
                raise ConfigError(f"invalid episode config {k}: {e}") from None
        kw[k] = v
    return dataclasses.replace(base, **kw)


def resolved_episode_config(cfg: NavigationConfig) -> dict:
    """The full EpisodeConfig (defaults filled in) plus camera and slice mode, as plain JSON."""
    return {"camera": cfg.camera, "slice_mode": cfg.slice_mode,
            **to_jsonable(build_episode_config(cfg.episode))}


def make_cells(inputs: list[LevelInputs], cfg: NavigationConfig) -> list[Cell]:
    """All cells of the grid, in (level, noise, estimator) order."""
    episode = resolved_episode_config(cfg)
    cells = []
    for li in inputs:
        for noise in cfg.noise:
            for est in cfg.estimators:
                options = dict(cfg.estimator_options.get(est, {}))
                key = config_hash({"level": li.level.key, "map_key": li.map.key, "task_set_key": li.tasks.key,
                                   "estimator": est, "estimator_options": options, "noise": noise,
                                   "episode": episode})
                cells.append(Cell(li.level.name, li.level.key, li.map.key, li.tasks.key, est, options,
                                  noise, dict(cfg.episode), key))
    return cells


def episode_seeds(level_key: str, task_id: int, seed: int) -> tuple[int, int]:
    """``(simulator seed, estimator seed)`` of an episode, from (level, task id, seed) only.

    Every estimator and noise level sees the same simulator noise stream for a given
    (level, task, seed): the seeds come from a :class:`numpy.random.SeedSequence` over the
    level's content key, the task id and the episode seed, never from the estimator.
    """
    ss = np.random.SeedSequence([int(level_key[:16], 16), int(task_id), int(seed)])
    sim, est = ss.spawn(2)
    return int(sim.generate_state(1, np.uint64)[0] >> np.uint64(1)), \
        int(est.generate_state(1, np.uint64)[0] >> np.uint64(1))


def episode_key(job: EpisodeJob) -> str:
    """Cache key of an episode's trajectory artifact."""
    from navbench.pipeline.cache import stage_key

    c = job.cell
    return stage_key("episode", {"cell": c.key, "task_id": job.task_id, "seed": job.seed},
                     {"level": c.level_key, "map": c.map_key, "tasks": c.tasks_key}, FORMAT["episode"])


# ---- episode records as compact npz files (generic over EpisodeRecord's fields)

TRAJ_FILE = "episode.npz"


def save_record(record: Any, path: Path) -> None:
    """Write a dataclass episode record to ``path`` (compressed npz): arrays as arrays, dicts of
    arrays (timings) as ``name/key`` arrays, everything else as JSON in ``__meta__``."""
    arrays: dict[str, np.ndarray] = {}
    meta: dict[str, Any] = {}
    for f in dataclasses.fields(record):
        v = getattr(record, f.name)
        if isinstance(v, np.ndarray):
            arrays[f.name] = v
        elif isinstance(v, dict) and v and all(isinstance(x, np.ndarray) for x in v.values()):
            for k, x in v.items():
                arrays[f"{f.name}/{k}"] = x
            meta.setdefault("__dicts__", []).append(f.name)
        else:
            meta[f.name] = to_jsonable(v)
    arrays["__meta__"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def load_record(path: Path, cls: type | None = None) -> Any:
    """Read a record written by :func:`save_record` (as ``cls``, default EpisodeRecord)."""
    if cls is None:
        from navbench.nav.episode import EpisodeRecord as cls  # noqa: N813
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(bytes(z["__meta__"]).decode())
        dict_fields = set(meta.pop("__dicts__", []))
        kw: dict[str, Any] = dict(meta)
        for name in z.files:
            if name == "__meta__":
                continue
            if "/" in name and name.split("/", 1)[0] in dict_fields:
                top, k = name.split("/", 1)
                kw.setdefault(top, {})[k] = z[name]
            else:
                kw[name] = z[name]
    names = {f.name for f in dataclasses.fields(cls)}
    for f in dataclasses.fields(cls):
        if f.name not in kw and f.name in dict_fields:
            kw[f.name] = {}
    return cls(**{k: v for k, v in kw.items() if k in names})


# ---- the worker side

_WORKER_MEMO: dict[tuple, Any] = {}


def _worker_inputs(spec: ChunkSpec):
    """Load (once per worker process) the level, map slice and tasks of a chunk."""
    memo_key = (spec.level_path, spec.map_path, spec.tasks_path, spec.slice_mode)
    hit = _WORKER_MEMO.get(memo_key)
    if hit is None:
        from navbench.levelio import load_level
        from navbench.plan.tasks import load_tasks
        from navbench.worldmodel.grid import load_map, occupancy_slice

        level = load_level(spec.level_path)
        vmap = load_map(spec.map_path)
        occ2d, xs, ys = occupancy_slice(vmap, spec.slice_mode)
        tasks = {t.id: t for t in load_tasks(spec.tasks_path)}
        hit = (level, vmap, occ2d, xs, ys, tasks)
        _WORKER_MEMO.clear()  # one level at a time keeps worker memory flat
        _WORKER_MEMO[memo_key] = hit
    return hit


def run_episode_chunk(spec: ChunkSpec) -> list[tuple[EpisodeJob, Any, Any]]:
    """Worker entry point: run a chunk's episodes; returns ``(job, record, score)`` triples."""
    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.nav.episode import run_episode
    from navbench.nav.metrics import score_episode
    from navbench.sim.world import Simulator
    from navbench.track.base import make_estimator

    level, vmap, occ2d, xs, ys, tasks = _worker_inputs(spec)
    intr = camera_by_name(spec.camera)
    out = []
    for job in spec.jobs:
        c = job.cell
        ep_cfg = build_episode_config(c.episode)
        frames = c.estimator not in FRAMELESS_ESTIMATORS
        sim = Simulator(level, noise=c.noise, seed=job.sim_seed, intrinsics=intr if frames else None,
                        camera_height=CAMERA_HEIGHT, enforce_direction_limit=ep_cfg.body_fixed_drive)
        est = make_estimator(c.estimator, vmap=vmap, intrinsics=intr, camera_height=CAMERA_HEIGHT,
                             renderer=None, seed=job.estimator_seed, **c.options)
        record = run_episode(level, occ2d, xs, ys, tasks[job.task_id], est, sim, config=ep_cfg)
        out.append((job, record, score_episode(record)))
    return out


# ---- the parent side

@dataclass
class NavigationSummary:
    """What run-navigation did: episode counts by origin and the cells it covered.

    ``already_done + stored == total`` once the grid is complete: every episode was either
    stored by this run or by another one (before it started, or while it ran).
    """

    cells: list[Cell]
    total: int = 0            # episodes in the grid
    already_done: int = 0     # stored by another run (before this one, or meanwhile)
    from_cache: int = 0       # trajectory artifact found, scored and stored without simulating
    ran: int = 0              # simulated now (including restored trajectories)
    stored: int = 0           # new database rows written by this run
    stored_elsewhere: int = 0  # of already_done: stored by another run while this one ran
    restored: int = 0         # stored episodes whose missing or corrupt trajectory was rewritten


def plan_jobs(inputs: list[LevelInputs], cfg: NavigationConfig) -> tuple[list[Cell], list[EpisodeJob]]:
    """Every episode of the grid (cells x tasks x seeds) in a stable order: level by level, and
    within a level task by task and seed by seed across all cells, so that a partial run holds
    comparable episodes of every estimator and noise level."""
    from navbench.plan.tasks import load_tasks

    cells = make_cells(inputs, cfg)
    jobs = []
    for li in inputs:
        level_cells = [c for c in cells if c.level_key == li.level.key]
        for tid in [t.id for t in load_tasks(li.tasks.path)]:
            for s in range(cfg.seeds):
                sim_seed, est_seed = episode_seeds(li.level.key, tid, s)
                jobs.extend(EpisodeJob(c, tid, s, sim_seed, est_seed) for c in level_cells)
    return cells, jobs


def _row(job: EpisodeJob, record: Any, score: Any, traj_key: str) -> dict:
    from navbench.pipeline.db import episode_row_from_score

    c = job.cell
    meta = {"level": c.level, "map_key": c.map_key, "task_set_key": c.tasks_key,
            "estimator": c.estimator, "estimator_options": c.options, "noise": c.noise,
            "seed": job.seed, "task_id": job.task_id,
            "timings_ms": getattr(record, "timings_ms", {}) or {},
            "end_reason": getattr(record, "end_reason", None),
            "collided": getattr(record, "collided", None)}
    return episode_row_from_score(c.key, meta, score, traj_key)


def _store_trajectory(ctx: StageContext, job: EpisodeJob, record: Any) -> str:
    """Write an episode's trajectory artifact (a valid one already there is kept: episodes are
    deterministic); returns its key."""
    key = episode_key(job)
    c = job.cell
    ctx.store.write("episode", key, lambda d: save_record(record, d / TRAJ_FILE),
                    config={"cell": c.key, "task_id": job.task_id, "seed": job.seed,
                            "level": c.level, "estimator": c.estimator, "noise": c.noise},
                    inputs={"level": c.level_key, "map": c.map_key, "tasks": c.tasks_key},
                    version=FORMAT["episode"])
    return key


def _triple(job: EpisodeJob) -> tuple[str, int, int]:
    return (job.cell.key, job.task_id, job.seed)


def _score_differs(stored: dict, score: Any) -> list[str]:
    """The fields of a stored episode row that a new simulation of it does not reproduce."""
    def same(a, b) -> bool:
        a = None if a is None or (isinstance(a, float) and a != a) else a
        b = None if b is None or (isinstance(b, float) and b != b) else b
        return a == b

    new = {"success": bool(score.success), "spl_term": float(score.spl_term),
           "path_length": float(score.path_length), "steps": int(score.steps)}
    return [f"{k} {stored[k]} -> {v}" for k, v in new.items() if not same(stored[k], v)]


def chunk_jobs(inputs: list[LevelInputs], cfg: NavigationConfig, jobs: list[EpisodeJob],
               chunk_size: int) -> list[ChunkSpec]:
    """Group jobs by level into chunks of at most ``chunk_size`` episodes (absolute paths, so
    workers with another working directory find the artifacts)."""
    by_level = {li.level.key: li for li in inputs}
    groups: dict[str, list[EpisodeJob]] = {}
    for j in jobs:
        groups.setdefault(j.cell.level_key, []).append(j)
    specs = []
    for lk, js in groups.items():
        li = by_level[lk]
        for i in range(0, len(js), chunk_size):
            specs.append(ChunkSpec(str(Path(li.level.path).resolve()), str(Path(li.map.path).resolve()),
                                   str(Path(li.tasks.path).resolve()), cfg.camera, cfg.slice_mode,
                                   tuple(js[i:i + chunk_size])))
    return specs


def run_navigation_stage(ctx: StageContext, run_id: int, inputs: list[LevelInputs],
                         cfg: NavigationConfig, executor=None, chunk_size: int | None = None,
                         on_progress: Callable[[int], None] | None = None,
                         on_total: Callable[[int], None] | None = None) -> NavigationSummary:
    """Run every episode of the grid that the database does not hold yet.

    Episodes already in the database are skipped; an episode whose trajectory artifact exists
    (a run killed between writing it and committing its row) is scored from it without
    simulating. The rest run in chunks on ``executor`` (see :mod:`navbench.pipeline.executor`;
    ``None`` runs them in this process). This process is the only writer: after each chunk it
    stores the trajectories in the cache and commits the chunk's rows in one transaction, so
    an interruption loses at most the chunks in flight, and a rerun finishes the rest.

    Another run of the same grid may work at the same time: just before a chunk is handed to a
    worker, its episodes that are stored by now are dropped from it, and rows that another run
    inserted first are counted as theirs (``stored`` counts only rows this run inserted).

    A stored episode whose trajectory artifact is missing or fails its checksum is simulated
    again (same seeds) and its artifact rewritten, without a new row; a score that differs from
    the stored one is reported as a warning and the stored row is kept.
    """
    from navbench.nav.metrics import score_episode

    cells, jobs = plan_jobs(inputs, cfg)
    summary = NavigationSummary(cells, total=len(jobs))
    stored_rows = ctx.db.episode_outcomes([c.key for c in cells])
    todo = [j for j in jobs if _triple(j) not in stored_rows]
    summary.already_done = len(jobs) - len(todo)
    # stored rows whose trajectory artifact is gone or damaged: simulate again to restore it
    restore = [j for j in jobs if _triple(j) in stored_rows
               and stored_rows[_triple(j)]["traj_key"] == episode_key(j)
               and ctx.store.lookup("episode", episode_key(j), ctx.log) is None]
    if restore:
        ctx.log(f"warning: {len(restore)} stored episode(s) have no valid trajectory artifact; "
                "simulating them again to restore it (their rows are kept)")
    if on_total:
        on_total(len(todo) + len(restore))
    # trajectories stored by an interrupted run: score them, no simulation
    rerun, rows = [], []
    for j in todo:
        key = episode_key(j)
        p = ctx.store.lookup("episode", key, ctx.log)
        if p is None:
            rerun.append(j)
            continue
        record = load_record(p / TRAJ_FILE)
        rows.append(_row(j, record, score_episode(record), key))
        ctx.used.append(("episode", key))
    if rows:
        new = ctx.db.add_episodes(run_id, rows)
        summary.stored += new
        summary.from_cache = len(rows)
        summary.already_done += len(rows) - new
        summary.stored_elsewhere += len(rows) - new
        if on_progress:
            on_progress(len(rows))
    work = rerun + restore
    if not work:
        return summary
    restoring = {_triple(j) for j in restore}
    if chunk_size is None:
        workers = getattr(executor, "workers", 1) or 1
        chunk_size = max(1, min(8, len(work) // (4 * workers) or 1))

    def still_missing(specs):
        """Each chunk without the episodes another run has stored since this one started
        (asked just before the chunk goes to a worker)."""
        for spec in specs:
            wanted = [_triple(j) for j in spec.jobs if _triple(j) not in restoring]
            there = ctx.db.stored_episode_keys(wanted) if wanted else set()
            if there:
                summary.already_done += len(there)
                summary.stored_elsewhere += len(there)
                if on_progress:
                    on_progress(len(there))
            left = tuple(j for j in spec.jobs if _triple(j) not in there)
            if left:
                yield dataclasses.replace(spec, jobs=left)

    specs = still_missing(chunk_jobs(inputs, cfg, work, chunk_size))
    results = executor.map_unordered(run_episode_chunk, specs) if executor is not None \
        else map(run_episode_chunk, specs)
    simulated_twice = 0
    for triples in results:
        batch = []
        for job, record, score in triples:
            key = _store_trajectory(ctx, job, record)
            ctx.used.append(("episode", key))
            if _triple(job) in restoring:
                summary.restored += 1
                differs = _score_differs(stored_rows[_triple(job)], score)
                if differs:
                    c = job.cell
                    ctx.log(f"warning: episode {c.level}/{c.estimator}/{c.noise} task {job.task_id} "
                            f"seed {job.seed} simulated again does not reproduce its stored score "
                            f"({', '.join(differs)}); the stored row is kept")
                continue
            batch.append(_row(job, record, score, key))
        new = ctx.db.add_episodes(run_id, batch) if batch else 0
        summary.stored += new
        summary.already_done += len(batch) - new
        summary.stored_elsewhere += len(batch) - new
        simulated_twice += len(batch) - new
        summary.ran += len(triples)
        if on_progress:
            on_progress(len(triples))
    if summary.stored_elsewhere:
        ctx.log(f"run-navigation: {summary.stored_elsewhere} episode(s) were stored by another run "
                f"while this one ran ({simulated_twice} of them simulated here too; the first "
                "stored row stays)")
    if summary.restored:
        ctx.log(f"run-navigation: restored {summary.restored} trajectory artifact(s) of stored episodes")
    return summary


# ----------------------------------------------------------------------------- score, report

def episodes_state_key(ctx: StageContext, cells: list[Cell]) -> str:
    """A key for everything stored about ``cells``: the sorted (cell, task, seed) triples."""
    done = sorted(ctx.db.done_episode_keys([c.key for c in cells]))
    return config_hash({"cells": sorted(c.key for c in cells), "episodes": [list(t) for t in done]})


SCORE_FILE = "score.csv"


def score_stage(ctx: StageContext, cells: list[Cell]) -> Ref:
    """The score table of exactly these cells (:func:`navbench.pipeline.score.select_episodes`
    restricted to the cells' keys, then :func:`~navbench.pipeline.score.summarise`), cached by
    the set of stored episodes; the artifact is ``score.csv``."""
    state = episodes_state_key(ctx, cells)
    levels = sorted({c.level for c in cells})

    def compute(d: Path) -> None:
        from navbench.pipeline.score import select_episodes, summarise

        frame = select_episodes(ctx.db, level=levels)
        if not frame.empty:
            frame = frame[frame["cell_key"].isin(cell_keys)]
        summarise(frame).to_csv(d / SCORE_FILE, index=False)

    cell_keys = sorted(c.key for c in cells)
    path, key, cached = ctx.run("score", {"levels": levels}, {"episodes": state}, compute)
    return Ref("score", key, path / SCORE_FILE, cached)


REPORT_INDEX = "index.html"


def report_stage(ctx: StageContext, cells: list[Cell], score: Ref) -> Ref:
    """The HTML report (:func:`navbench.pipeline.report.build_report`) of these cells' episodes
    (as the score stage), with trajectories and maps read from this store, cached by the score
    artifact and the cells' stored episodes (so a rerun that adds nothing does not redraw it;
    its run list is as of the last redraw)."""
    state = episodes_state_key(ctx, cells)

    def compute(d: Path) -> None:
        from navbench.pipeline.report import build_report, store_loaders

        load_trajectory, load_map = store_loaders(ctx.store.root)
        index = Path(build_report(ctx.db, d, load_trajectory, load_map, levels_dir=ctx.levels_dir,
                                  cell_keys=[c.key for c in cells]))
        if index.name != REPORT_INDEX or index.parent.resolve() != d.resolve():
            raise ArtifactError(f"build_report wrote {index}, expected {d / REPORT_INDEX}")

    path, key, cached = ctx.run("report", {"format": 1}, {"score": score.key, "episodes": state}, compute)
    return Ref("report", key, path / REPORT_INDEX, cached)
