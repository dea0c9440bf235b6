"""sample-tasks: a level's navigation task set (committed under ``tasks/`` or sampled and cached),
checked against its level before any episode runs."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from navbench.errors import ConfigError
from navbench.pipeline.artifacts import TASKS_FILE, _sha256_text
from navbench.pipeline.stages.context import Ref, StageContext, verified
from navbench.pipeline.stages.level import load_level_ref


@dataclass(frozen=True)
class TasksConfig:
    """sample-tasks: ``count`` tasks sampled on the true geometry from ``seed``
    (constraints: :func:`navbench.plan.tasks.sample_tasks`)."""

    count: int = 30
    seed: int = 0
    # issue 15: NRNS difficulties ("easy", "medium", "hard"): ``count`` tasks of each, by exact
    # geodesic distance (navbench.plan.tasks.sample_tasks_by_difficulty); () = any distance,
    # and then left out of the key (task sets sampled before keep theirs)
    difficulty: tuple[str, ...] = ()

    def __post_init__(self):
        if self.count < 1:
            raise ConfigError(f"task count must be >= 1, got {self.count}")
        from navbench.nav.presets import DIFFICULTY_BANDS

        bad = [d for d in self.difficulty if d not in DIFFICULTY_BANDS]
        if bad or len(set(self.difficulty)) != len(self.difficulty):
            raise ConfigError(f"[tasks] difficulty: expected distinct names of {', '.join(DIFFICULTY_BANDS)}, "
                              f"got {list(self.difficulty)}")

    def key_config(self) -> dict:
        """The config as hashed into the sample-tasks key (``difficulty`` only when given)."""
        d = {"count": self.count, "seed": self.seed}
        return {**d, "difficulty": list(self.difficulty)} if self.difficulty else d


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
    # a committed file holds tasks of any distance: never the tasks of a difficulty
    committed = None if cfg.difficulty else committed_task_file(ctx.tasks_dir, level, cfg)
    if committed is not None:
        path, cached = committed, True
        ctx.log(f"sample-tasks: {level.name} from {committed}")
    else:
        def compute(d: Path) -> None:
            from navbench.plan.tasks import load_tasks, sample_tasks, save_tasks

            larger = None if cfg.difficulty else committed_task_file(ctx.tasks_dir, level, cfg, prefix_ok=True)
            if cfg.difficulty:
                from navbench.plan.tasks import sample_tasks_by_difficulty

                tasks = sample_tasks_by_difficulty(load_level_ref(level), cfg.count, cfg.seed, cfg.difficulty)
            elif larger is not None:
                ctx.log(f"sample-tasks: {level.name}: the first {cfg.count} tasks of {larger}")
                tasks = load_tasks(larger)[:cfg.count]
                from navbench.plan.tasks import check_tasks_on_level

                # checked here, so that an error names the file the user edited, not the
                # cache's copy of its first tasks (issue 34)
                check_tasks_on_level(load_level_ref(level), tasks, str(larger))
            else:
                tasks = sample_tasks(load_level_ref(level), cfg.count, cfg.seed)
            save_tasks(d / TASKS_FILE, level.name, tasks, level_hash=level.key, seed=cfg.seed)

        adir, _, cached = ctx.run("sample-tasks", cfg.key_config(), {"level": level.key}, compute)
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
