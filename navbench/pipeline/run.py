"""Running a profile from Python: :func:`run_profile`, and the run bookkeeping every command shares.

The library entry point behind ``navbench all`` and ``navbench run-navigation``::

    from navbench.pipeline.run import run_profile

    result = run_profile("quick", workers=2, progress=True)   # stage lines and bars, as the CLI
    print(result.scores[["level", "estimator", "noise", "success_rate", "spl"]])
    print(result.report_path)                          # results/report/index.html, as `navbench all`

:func:`recorded_run` records a run's start, finish and failure in the results database (one
row of ``runs``: done, failed or interrupted) and names the artifacts it touched as a cache ref
(a gc root); ``run-navigation``, ``all``, ``track-eval`` and ``bench`` all go through it.

Progress is reported through a :class:`Progress` (log lines, progress bars); the default
:class:`SilentProgress` prints nothing, ``progress=True`` draws the CLI's stage lines and rich
bars, and a function receives the same lines as text (:class:`navbench.pipeline.console.CallbackProgress`).
"""

from __future__ import annotations

import dataclasses
import os
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator, Protocol

if TYPE_CHECKING:
    import pandas

    from navbench.results.db import ResultsDB
    from navbench.pipeline.profiles import Profile
    from navbench.pipeline.stages import LevelInputs, NavigationSummary, Ref, StageContext

#: How far :func:`run_profile` goes: the episodes only, or also the score table and the report.
UNTIL = ("navigation", "score", "report")
#: Where :func:`run_profile` publishes the report by default: where ``navbench all`` does.
DEFAULT_REPORT_DIR = "results/report"
_UNSET: Any = object()


class Progress(Protocol):
    """Where a run reports what it does (the CLI draws rich bars; a library caller may log)."""

    def log(self, msg: str) -> None:
        """One line about a stage (``fit-map: cached 1a2b3c``, warnings start with ``warning``)."""

    def bar(self, description: str, total: int | None, unit: str = "it") -> Callable[..., None]:
        """A bar set by ``update(done, total=None, loss=None)``."""

    def counter(self, description: str, total: int, unit: str = "ep") -> tuple[Callable[[int], None], Callable[[int], None]]:
        """A bar driven by increments: ``(advance(n), set_total(total))``."""


class SilentProgress:
    """A :class:`Progress` that reports nothing."""

    def log(self, msg: str) -> None:
        pass

    def bar(self, description: str, total: int | None, unit: str = "it"):
        return lambda *a, **k: None

    def counter(self, description: str, total: int, unit: str = "ep"):
        return (lambda n: None), (lambda t: None)


def stage_context(progress: Progress | None = None, db: "ResultsDB | None" = None,
                  force: bool | set[str] = False, cache_root: str | Path | None = None,
                  levels_dir: str | Path = "levels", tasks_dir: str | Path = "tasks") -> "StageContext":
    """A :class:`~navbench.pipeline.stages.StageContext` reporting through ``progress``.

    ``force``: ``True`` recomputes every stage, a set names the stages to recompute.
    """
    from navbench.pipeline.cache import ArtifactStore
    from navbench.pipeline.stages import StageContext

    progress = progress or SilentProgress()
    force = {"*"} if force is True else set(force or ())

    def bar(desc: str, total: int):
        unit = "views" if desc.startswith("views") else "steps" if desc.startswith("fit") else "it"
        return progress.bar(desc, total, unit)

    return StageContext(ArtifactStore(cache_root), db, log=progress.log, progress=bar,
                        force=frozenset(force), levels_dir=Path(levels_dir), tasks_dir=Path(tasks_dir))


@contextmanager
def open_db(db: "ResultsDB | str | None") -> Iterator["ResultsDB"]:
    """``db`` itself when it is a :class:`~navbench.results.db.ResultsDB` (left open), else the
    database at URL ``db`` (``None``: ``$NAVBENCH_DB`` or the default SQLite file), closed after."""
    from navbench.results.db import ResultsDB

    if isinstance(db, ResultsDB):
        yield db
        return
    handle = ResultsDB(db)
    try:
        yield handle
    finally:
        handle.close()


@contextmanager
def recorded_run(db: "ResultsDB", profile: str, command: str, config: Any,
                 ctx: "StageContext | None" = None, ref_name: str | None = None,
                 sim: str = "pymunk", benchmark_version: str | None = None) -> Iterator[int]:
    """Record a run around the block; yields its run id.

    The run row starts as ``running``; it ends ``done`` when the block returns, ``interrupted``
    on Ctrl-C (``KeyboardInterrupt``) and ``failed`` on any other exception, which propagate;
    a :class:`~navbench.errors.NavbenchError` (bad input) before the run stored any row deletes
    the run instead (:meth:`ResultsDB.discard_run`), so no later run resumes it.
    With ``ctx`` and ``ref_name``, the artifacts the block touched (``ctx.used``) become the
    cache ref ``ref_name`` (a gc root), also after a failure, so a resumed run finds them.
    The run row's benchmark version (which every episode row it stores copies) is ``config``'s
    ``benchmark_version`` (a profile's; the argument ``benchmark_version`` where given, as
    track-eval's), else :data:`navbench.benchmark.BENCHMARK_VERSION`,
    named with the simulator ``sim`` that produces the run's results unless it is pymunk
    (:func:`navbench.benchmark.sim_version`: ``navbench-1+vizdoom``).
    """
    from navbench.config import config_hash, to_jsonable

    from navbench.errors import NavbenchError

    cfg = to_jsonable(config)
    from navbench.benchmark import BENCHMARK_VERSION, sim_version

    version = benchmark_version or getattr(config, "benchmark_version", None) or BENCHMARK_VERSION
    run_id = db.start_run(profile, command, cfg, config_hash(cfg),
                          benchmark_version=sim_version(version, sim))
    status = "failed"
    try:
        yield run_id
        status = "done"
    except KeyboardInterrupt:
        status = "interrupted"
        raise
    except NavbenchError:
        # bad input (a misspelt level, an option the stage refuses): a run that stored nothing
        # is not recorded as one, so no later run "resumes" it; one that stored rows stays, failed
        if db.discard_run(run_id):
            status = None
        raise
    finally:
        if status is not None:
            db.finish_run(run_id, status)
        # an unfinished run adds to its ref, never replaces it; a refused one (discarded: it
        # stored nothing) writes none, as a refused command writes nothing
        if ctx is not None and ref_name and ctx.used and status is not None:
            ctx.store.set_ref(ref_name, ctx.used, merge=status != "done")


def navigation_config(profile: "Profile"):
    """The profile's run-navigation grid (:class:`~navbench.pipeline.stages.NavigationConfig`),
    before image goals or the unknown-house loop are added (:func:`navigate`)."""
    from navbench.pipeline.stages import NavigationConfig

    return NavigationConfig(estimators=tuple(profile.estimators), noise=tuple(profile.noise),
                            seeds=profile.seeds, camera=profile.camera, episode=dict(profile.episode),
                            estimator_options=dict(profile.estimator_options), goal=profile.goal,
                            benchmark_version=profile.benchmark_version, sim=profile.sim)


def navigate(ctx: "StageContext", profile: "Profile", run_id: int, executor: str = "local",
             address: str | None = None, chunk_size: int | None = None,
             progress: Progress | None = None,
             overlap: bool = True) -> tuple[list["LevelInputs"], "NavigationSummary"]:
    """Build (or fetch) every level's inputs, then run the episodes the database lacks.

    ``overlap`` (several levels, a fitted map, more than one worker): the levels after the first
    are built in a background process while the episodes of the levels before them run, and the
    episodes run level by level (:mod:`navbench.pipeline.overlap`; the same artifacts, keys and
    rows). ``False``: every level's inputs first, then every episode, one after the other.

    Returns ``(level inputs, NavigationSummary)``; the summary's ``seconds`` and ``workers`` are
    the navigation stage's wall-clock time and the executor's worker count (the breakdown's).
    """
    import time

    from navbench.pipeline.executor import make_executor
    from navbench.pipeline.stages import build_level_inputs, run_navigation_stage

    progress = progress or SilentProgress()
    if executor == "local":  # stages that split items over local processes (image goals); 0: every CPU
        from navbench.pipeline.executor import default_workers

        ctx.workers = int(profile.workers) or default_workers()
    if ctx.db is not None:
        from navbench.results.db.resume import resume_chain

        earlier = resume_chain(ctx.db.runs_frame(), run_id)[:-1]
        if earlier:
            ctx.log(f"run {run_id} resumes run(s) {', '.join(map(str, earlier))} of the same setup, "
                    "which did not finish (score --run latest takes them together)")
    if profile.map_source == "fit":
        from navbench.track.registry import uses_map

        if not any(uses_map(e) for e in profile.estimators):  # issue 35: say why a map is fitted
            ctx.log(f"fit-map: {', '.join(profile.estimators)} track without the map, but the agent "
                    "plans its path on it; --map true plans on the true geometry and fits nothing")
    from navbench.pipeline.stages.inputs import under_version
    from navbench.pipeline.versioning import departures, version_line

    if departures(profile):  # issue 36: a run of its version, but not the version's own settings
        ctx.log(f"warning: {version_line(profile)}")
    from navbench.pipeline.profiles import ignored_textures_note

    ignored = ignored_textures_note(profile)
    if ignored:  # an engine draws its own textures (navbench-2's texel tables change no frame there)
        ctx.log(f"warning: {ignored}")
    under_version(ctx, profile)  # every stage of the run, the levels checked up front included
    cfg = navigation_config(profile)
    from navbench.pipeline.stages.online import online_config

    online = online_config(profile.map_source, profile.online_ablation)
    goals = False
    if online is not None:  # issue 15 §5: the unknown-house loop; no goal is localised beforehand
        from navbench.pipeline.stages.goals import ImageGoalConfig

        cfg = dataclasses.replace(cfg, image_goal=ImageGoalConfig(camera=profile.camera), online=online)
    elif cfg.goal == "image":  # issue 15: every task's goal image localised in the level's map
        from navbench.pipeline.stages.goals import ImageGoalConfig

        cfg = dataclasses.replace(cfg, image_goal=ImageGoalConfig(camera=profile.camera,
                                                                  localizer=dict(profile.goal_localizer)))
        goals = True
    bar: dict[str, Any] = {"total": 0}

    def on_total(n: int) -> None:  # called once per navigation stage (per level with overlap)
        bar["total"] += n
        if "advance" in bar:
            bar["set_total"](bar["total"])
        elif n:
            bar["advance"], bar["set_total"] = progress.counter("episodes", bar["total"], unit="ep")

    def on_progress(n: int) -> None:
        if "advance" in bar:
            bar["advance"](n)

    from navbench.pipeline.overlap import overlap_applies

    why_not = overlap_applies(profile, executor, ctx.workers if executor == "local" else 0) if overlap \
        else "switched off"
    if why_not is None:
        inputs, summary = _navigate_overlapped(ctx, profile, run_id, cfg, goals, executor, address,
                                               chunk_size, progress, on_total, on_progress)
    else:
        inputs = [build_level_inputs(ctx, profile, name) for name in dict.fromkeys(profile.levels)]
        if goals:
            from navbench.pipeline.stages.inputs import with_image_goals

            inputs = [with_image_goals(ctx, li, cfg.image_goal, cfg.sim) for li in inputs]
        with make_executor(executor, profile.workers, address) as ex:
            t0 = time.perf_counter()
            summary = run_navigation_stage(ctx, run_id, inputs, cfg, executor=ex, chunk_size=chunk_size,
                                           on_progress=on_progress, on_total=on_total)
            summary.seconds = time.perf_counter() - t0
            summary.workers = int(getattr(ex, "workers", None) or 1)
    ctx.log(f"run-navigation: {summary.total} episodes in {len(summary.cells)} cells: "
            f"{summary.already_done} already stored, {summary.from_cache} from stored trajectories, "
            f"{summary.ran} run now")
    return inputs, summary


def _navigate_overlapped(ctx: "StageContext", profile: "Profile", run_id: int, cfg, goals: bool,
                         executor: str, address: str | None, chunk_size: int | None, progress: Progress,
                         on_total, on_progress) -> tuple[list["LevelInputs"], "NavigationSummary"]:
    """:func:`navigate` level by level, the levels after the first built in a background
    process beside the episodes (:mod:`navbench.pipeline.overlap`); the same artifacts, keys and
    rows as without overlap. ``summary.seconds`` is the episodes' wall-clock time, summed over
    the levels (waits for a level's inputs excluded)."""
    import time

    from navbench.pipeline.executor import make_executor, numba_threads
    from navbench.pipeline.overlap import Prefetcher, starts_at_once, summed_summary
    from navbench.pipeline.stages import build_level_inputs, run_navigation_stage
    from navbench.pipeline.stages.level import LevelConfig, make_level_stage

    names = list(dict.fromkeys(profile.levels))
    for name in names:  # a misspelt level fails before any work, as without overlap (cheap, cached)
        make_level_stage(ctx, LevelConfig(name, profile.level_seed))
    inputs, parts = [], []
    with Prefetcher(profile, names[1:], ctx, progress.log, ctx.progress) as pre, \
            make_executor(executor, profile.workers, address) as ex:
        before: list[int] = []  # this process's numba threads before the background took a core

        def start() -> None:  # the background on one thread, and this process on the rest
            if pre.start():
                before.append(numba_threads((os.cpu_count() or 1) - 1))

        if starts_at_once():
            start()
        for i, name in enumerate(names):
            if i:
                t0 = time.perf_counter()
                ctx.prefetched.update(pre.wait(name))
                waited = time.perf_counter() - t0
                if waited >= 1.0:
                    ctx.log(f"overlap: waited {waited:.1f} s for {name}'s inputs (its fit outlasted "
                            f"the episodes before it)")
            # or the background starts once the first level's views are there (starts_at_once)
            li = build_level_inputs(ctx, profile, name, before_fit=None if i else start)
            if before:  # the first level is built: its episodes run in the workers
                numba_threads(before.pop())
            if goals:
                from navbench.pipeline.stages.inputs import with_image_goals

                li = with_image_goals(ctx, li, cfg.image_goal, cfg.sim)
            inputs.append(li)
            t0 = time.perf_counter()
            part = run_navigation_stage(ctx, run_id, [li], cfg, executor=ex, chunk_size=chunk_size,
                                        on_progress=on_progress, on_total=on_total)
            part.seconds = time.perf_counter() - t0
            parts.append(part)
        workers = int(getattr(ex, "workers", None) or 1)
    summary = summed_summary(parts)
    summary.workers = workers
    return inputs, summary


@dataclass(frozen=True)
class RunResult:
    """What :func:`run_profile` did.

    ``run_id``: the run's row in the results database; ``profile``: the resolved profile;
    ``inputs``: each level's level, map and task-set references; ``navigation``: episode counts;
    ``score`` / ``report``: the score and report artifacts (``None`` when not run);
    ``report_path``: the published report's ``index.html`` (or the cached one when not
    published); ``refs``: every (stage, key) the run touched; ``breakdown``: where the time
    went, per stage and per episode component (:mod:`navbench.results.breakdown`; stored in
    the database's ``run_timings`` with the run).
    """

    run_id: int
    profile: "Profile"
    inputs: list["LevelInputs"]
    navigation: "NavigationSummary"
    score: "Ref | None" = None
    report: "Ref | None" = None
    report_path: Path | None = None
    refs: list[tuple[str, str]] = field(default_factory=list)
    breakdown: list[dict] = field(default_factory=list)

    @property
    def scores(self) -> "pandas.DataFrame":
        """The score table (one row per level x estimator x noise cell; empty before score)."""
        import pandas as pd

        if self.score is None:
            return pd.DataFrame()
        return pd.read_csv(self.score.path)


def run_profile(profile: "Profile | str | None" = "quick", *, db: "ResultsDB | str | None" = None,
                executor: str = "local", workers: int | None = None, address: str | None = None,
                chunk_size: int | None = None, progress: "Progress | bool | Callable[[str], None] | None" = None,
                until: str = "report", report_dir: str | Path | None = _UNSET,
                cache_root: str | Path | None = None, command: str | None = None,
                ref_name: str = "all", sets: list[str] | None = None, overlap: bool = True) -> RunResult:
    """Run a profile end to end: make-level -> collect-views -> fit-map -> sample-tasks ->
    run-navigation -> score -> report, every stage cached and the run recorded.

    ``profile``: a :class:`~navbench.pipeline.profiles.Profile`, or a bundled profile name or a
    ``.toml`` path. ``db``: a results database or its URL (default ``$NAVBENCH_DB`` or
    ``sqlite:///results/navbench.db``). ``executor``: ``local`` (a process pool of ``workers``;
    0 = CPU count, 1 = in this process) or ``ray`` (at ``address``). ``until``: ``navigation``,
    ``score`` or ``report`` (see :data:`UNTIL`). ``report_dir``: where to publish the report
    (checked before any work; a folder that is new, empty or a report published before); by
    default ``results/report``, as ``navbench all``, so ``RunResult.report_path`` is the page
    the CLI names; ``None``: not published (the path is the cached page's). ``progress``:
    ``None``/``False`` silent (library use), ``True`` the CLI's stage lines and bars (stdout),
    a function ``f(line)`` each stage line and bar state as text, or a :class:`Progress`.
    ``sets``: ``--set`` items (``["fit.steps=300", "tasks.count=3"]``,
    :mod:`navbench.pipeline.overrides`). ``overlap``: build the next levels' views and maps in a
    background process while a level's episodes run (:func:`navigate`; results identical either
    way, so it is no part of any key or of the run's recorded config).
    Episodes already stored are skipped, so a rerun resumes; a run interrupted by Ctrl-C is
    recorded as interrupted and the ``KeyboardInterrupt`` propagates; so is one ended by SIGTERM
    (handled as a Ctrl-C while the run works, :func:`navbench.interrupts.terminate_as_interrupt`).
    """
    from navbench.errors import ConfigError
    from navbench.results.breakdown import breakdown_rows
    from navbench.pipeline.profiles import Profile, load_profile, override
    from navbench.report.publish import check_report_dir, protected_paths, publish
    from navbench.pipeline.stages import report_stage, score_stage

    if until not in UNTIL:
        raise ConfigError(f"until: unknown stage {until!r}; choose from {', '.join(UNTIL)}")
    if report_dir is _UNSET:
        report_dir = DEFAULT_REPORT_DIR if until == "report" else None
    elif report_dir is not None and until != "report":
        raise ConfigError("report_dir: a report is published only with until='report'")
    if progress is True or callable(progress) and not hasattr(progress, "log"):
        from navbench.pipeline.console import CallbackProgress, PipelineUI

        if progress is not True:
            progress = CallbackProgress(progress)
        else:
            with PipelineUI() as ui:
                return run_profile(profile, db=db, executor=executor, workers=workers, address=address,
                                   chunk_size=chunk_size, progress=ui, until=until, report_dir=report_dir,
                                   cache_root=cache_root, command=command, ref_name=ref_name, sets=sets,
                                   overlap=overlap)
    elif progress is False:
        progress = None
    prof = profile if isinstance(profile, Profile) else load_profile(profile)
    if sets:
        from navbench.pipeline.overrides import apply_sets

        prof = apply_sets(prof, sets, "sets")
    prof = override(prof, workers=workers)
    from navbench.pipeline.stages.online import online_profile

    prof = online_profile(prof, (progress or SilentProgress()).log)  # --map online: checked, nrns
    protected = protected_paths(db if db is None or isinstance(db, str) else db.url, cache_root)
    if report_dir is not None:
        check_report_dir(report_dir, "--report", protected)  # before hours of work, not after
    from navbench.pipeline.executor import check_executor

    check_executor(executor, prof.workers, address)  # before the run row (no failed run to resume)
    from navbench.sim.backends import require_sim

    require_sim(prof.sim, f"profile {prof.name}: sim")  # vizdoom installed? before the run row
    progress = progress or SilentProgress()
    import time

    from navbench.interrupts import terminate_as_interrupt

    t_start = time.perf_counter()
    with open_db(db) as rdb, terminate_as_interrupt():
        ctx = stage_context(progress, rdb, cache_root=cache_root)
        command = command or f"run_profile({prof.name!r})"
        ref = f"{ref_name}-{prof.name}"
        with recorded_run(rdb, prof.name, command, prof, ctx, ref, sim=prof.sim) as run_id:
            inputs, summary = navigate(ctx, prof, run_id, executor, address, chunk_size, progress, overlap)
            score = score_stage(ctx, summary.cells, preset=prof.scoring_preset) \
                if until in ("score", "report") else None
        # The run is marked done before its report is drawn, so the page it publishes shows it
        # finished; a report that fails marks it failed (or interrupted) after all.
        report = None
        if until == "report":
            failed = True
            try:
                report = report_stage(ctx, summary.cells, score, preset=prof.scoring_preset)
                failed = False
            except BaseException as e:
                rdb.finish_run(run_id, "interrupted" if isinstance(e, KeyboardInterrupt) else "failed")
                raise
            finally:
                if ctx.used:
                    ctx.store.set_ref(ref, ctx.used, merge=failed)
        # Where the time went, the report stage included: stored with the (finished) run.
        breakdown = breakdown_rows(ctx.timings, summary, summary.seconds, summary.workers,
                                   wall_s=time.perf_counter() - t_start)
        rdb.add_run_timings(run_id, breakdown)
    report_path = report.path if report is not None else None
    if report is not None and report_dir is not None:
        report_path = publish(report.path.parent, Path(report_dir), protected, "--report") / report.path.name
    return RunResult(run_id, prof, inputs, summary, score, report, report_path, list(ctx.used), breakdown)
