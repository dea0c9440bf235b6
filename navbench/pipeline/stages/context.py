"""What every stage receives (:class:`StageContext`) and returns (:class:`Ref`), and the cached
check that lets a stage verify an input once per content (:func:`verified`)."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from navbench.benchmark import LEGACY_VERSION, affected_stages, key_part
from navbench.config import to_jsonable
from navbench.pipeline.cache import ArtifactStore, run_stage
from navbench.pipeline.artifacts import FORMAT, VERIFY_FILE


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
    ``workers``: local processes a stage may split independent items over (the image goals'
    localisations); how a stage runs, never part of a key: its artifact is the same for any.
    ``benchmark_version``: the version the stages run under; the key of every stage it affects
    (:func:`navbench.benchmark.affected_stages`) carries it (:func:`navbench.benchmark.key_part`,
    nothing for ``navbench-1``). A profile's stages set it from the profile
    (:func:`navbench.pipeline.stages.inputs.build_level_inputs`).
    """

    store: ArtifactStore
    db: Any = None
    log: Callable[[str], None] = _noop
    progress: Callable[[str, int], Callable[[int], None]] = lambda desc, total: _noop
    force: frozenset = frozenset()
    levels_dir: Path = Path("levels")
    tasks_dir: Path = Path("tasks")
    used: list = field(default_factory=list)   # (stage, key) pairs touched: gc roots
    # (stage, seconds, cached) of every run() call: the per-stage breakdown (pipeline.breakdown);
    # (stage, seconds, False, True) for a stage another process computed for this run
    timings: list = field(default_factory=list)
    workers: int = 1
    benchmark_version: str = LEGACY_VERSION
    # (stage, key) -> seconds: artifacts this run's prefetch process computed (pipeline.overlap);
    # found cached here, they are reported as computed beside the episodes, with its seconds
    prefetched: dict = field(default_factory=dict)

    def keyed(self, stage: str, config: Any) -> Any:
        """``config`` as ``stage``'s key hashes it under this context's benchmark version (its
        :func:`~navbench.benchmark.key_part` where the version's settings reach the stage)."""
        if stage in affected_stages(self.benchmark_version):
            return {**to_jsonable(config), **key_part(self.benchmark_version)}
        return config

    def forced(self, stage: str) -> bool:
        return "*" in self.force or stage in self.force

    def run(self, stage: str, config: Any, inputs: dict[str, str],
            compute: Callable[[Path], None],
            validate: Callable[[Path], None] | None = None) -> tuple[Path, str, bool]:
        t0 = time.perf_counter()
        config = self.keyed(stage, config)
        log = self.log
        if self.prefetched:  # "cached" is what this process saw; say who computed it
            def log(msg: str) -> None:
                key = msg.rsplit(" ", 1)[-1]
                if msg.startswith(f"{stage}: cached ") and any(
                        s == stage and k.startswith(key) for s, k in self.prefetched):
                    msg = f"{stage}: {key}, computed in the background beside the episodes"
                self.log(msg)
        path, key, cached = run_stage(self.store, stage, config, inputs, FORMAT[stage], compute,
                                      force=self.forced(stage), log=log, validate=validate)
        if cached and (stage, key) in self.prefetched:
            self.timings.append((stage, self.prefetched.pop((stage, key)), False, True))
        else:
            self.timings.append((stage, time.perf_counter() - t0, bool(cached)))
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
