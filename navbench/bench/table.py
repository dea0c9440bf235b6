"""The measurement table of ``navbench bench``: one :class:`Measurement` row per result key.

A row declares everything about one key of the result: its group and label, its unit, what it
runs (a timer of :mod:`navbench.bench.timers`, or a value derived from rows above it), how many
repeats it takes from the configured count (quick and full runs), the shared inputs it uses
(:data:`SHARED`: a recorded walk, the end-to-end run), when it cannot be measured and why
(``needs``: no CUDA device, an estimator that does not exist, ...), the device it runs on, the
paper's figure to compare with and the note that explains it. :func:`~navbench.bench.run.run_bench`
runs the rows in order; a derived row reads the :class:`Metric` of rows above it from
:attr:`BenchContext.metrics`. The order of :data:`TABLE` is the order of :func:`metric_keys`.

:data:`TARGETS` are the speed targets of issue #7, in the issue's order (the result's
``targets`` list keeps it); each names a key of the table.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, NamedTuple

from navbench.bench import timers
from navbench.bench.core import (
    EMISSION_STEPS,
    FIT_STEPS,
    PAPER_FIGURES,
    QUICK_EMISSION_STEPS,
    BenchConfig,
    Metric,
    Stats,
    Target,
)
from navbench.geometry import CAMERA_NAMES, CAMERAS

#: The version the ``_v5`` rows measure beside navbench-1 (issue 36: "the bench measures both
#: versions side by side"): the newest accepted version, the next default's candidate. Until
#: 2026-11-27 these rows were ``_v2``, navbench-2's, whose acceptance grid failed (their figures:
#: docs/notebook/speed.md); docs/data/speed/versions_ab.py measures any number of versions.
VERSUS = "navbench-5"
#: The suffix of :data:`VERSUS`'s rows: ``_v5`` for navbench-5.
_VS = f"_v{VERSUS.rsplit('-', 1)[1]}"

TARGETS: tuple[Target, ...] = (
    Target("render_ms_paper", "<=", 10.0, "map render, paper camera <= 10 ms"),
    Target("track_ms_ours_paper", "<=", 30.0, "ours tracking step, paper camera <= 30 ms"),
    Target("control_step_hz_paper", ">=", 20.0, "full control step, paper camera >= 20 Hz"),
    Target("control_step_hz_half", ">=", 50.0, "full control step, half camera >= 50 Hz"),
    Target("emission_ours_ratio_half", ">=", 4.0,
           "emission / ours step time, equal pixel budget >= 4"),
    Target("fit_10k_steps_s", "<=", 180.0,
           "fit-map 10 000 steps <= 3 min (extrapolated from one step)"),
    # issue #17: the agent's own step (without the simulator's camera) and the rate with it
    Target("agent_step_ms_paper", "<=", 8.0, "agent step (render + track + plan + control), paper camera <= 8 ms"),
    Target("control_step_hz_paper", ">=", 75.0, "full control step, paper camera >= 75 Hz"),
    # issue 36: the version under test against navbench-1 in the same bench run
    Target(f"agent_step_ms_paper_ref05{_VS}", "<=", 5.0, f"agent step under {VERSUS}, paper camera <= 5 ms"),
    Target(f"e2e{_VS}_over_v1_paper_ref05", ">=", 2.0, f"episodes a minute, {VERSUS} / navbench-1 >= 2"),
)

#: ours' options of the ``_ref05`` rows (issue 17, part 2).
REF05 = {"reference_scale": 0.5}


def version_levers(version: str) -> tuple[dict, dict]:
    """``(estimator options by name, episode settings)`` that benchmark ``version`` fixes
    (its :func:`navbench.benchmark.settings_document`), for the bench rows that measure a
    version beside navbench-1 in the same run."""
    from navbench.benchmark import settings_document

    nav = settings_document(version).get("navigation", {})
    return nav.get("options", {}), nav.get("episode", {})


def paper_levers(version: str) -> tuple[dict, dict]:
    """``version``'s levers (:func:`version_levers`) with ``ours`` at the paper profile's
    ``reference_scale`` 0.5 under them: ``(estimator options by name, episode settings)``."""
    options, episode = version_levers(version)
    return {**options, "ours": {**REF05, **options.get("ours", {})}}, episode


def _versus_ours() -> dict:
    """The ``time_control_step`` keywords of ours under :data:`VERSUS`: its ``options`` (the paper
    profile's ``reference_scale`` 0.5 and the version's levers) and the camera's ``texture``."""
    options, episode = paper_levers(VERSUS)
    return {"options": options["ours"], "texture": episode.get("texture", "procedural")}


TRACKERS = (  # (key part, estimator name, options, label)
    ("ours", "ours", {}, "ours, default"),
    ("ours_adam", "ours", {"optimizer": "adam"}, "ours, Adam 100x1000 px"),
    ("ours_gauss_newton", "ours", {"optimizer": "gauss-newton"}, "ours, Gauss-Newton"),
    ("no_map", "no-map", {}, "no-map, default"),
    ("emission", "emission", {}, "emission, Adam 100x1000 px"),
)
#: Untimed tracking steps before the timed ones (the emission update takes 1: it is slow).
TRACK_WARMUP = 2


# ---------------------------------------------------------------------------------- the rows' types

@dataclass
class BenchContext:
    """What every row shares, built once per run: the config, the level (and its committed file,
    if any), the map and its description, the fast renderer's sample spacing ``step`` (m), the
    estimators that exist, whether the CUDA rows run, the progress callback, the rows measured so
    far (``metrics``) and the shared inputs built so far (``shared``, see :meth:`use`)."""

    cfg: BenchConfig
    level: Any
    level_file: Path | None
    vmap: Any
    map_desc: str
    step: float
    available: frozenset[str]
    use_cuda: bool
    say: Callable[[str], None] = lambda _label: None
    metrics: dict[str, Metric] = field(default_factory=dict)
    shared: dict[str, Any] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return self.cfg.n

    @property
    def budget(self) -> float:
        return self.cfg.budget

    @property
    def seed(self) -> int:
        return self.cfg.seed

    @property
    def quick(self) -> bool:
        return self.cfg.quick

    def value(self, key: str) -> float | None:
        """The value of a row measured above (None when it is n/a)."""
        return self.metrics[key].value

    def use(self, name: str) -> Any:
        """The shared input ``name`` of :data:`SHARED`, built (and announced) on first use."""
        if name not in self.shared:
            progress, build = SHARED[name]
            self.say(progress(self))
            self.shared[name] = build(self)
        return self.shared[name]


class Reading(NamedTuple):
    """What a row's ``run`` returns when a bare list or number is not enough: timed repeats
    (``times``) or a derived ``value`` with optional ``stats``, and a ``note``/``label`` that
    replace the row's own (they depend on what was measured)."""

    times: list[float] | None = None
    value: float | None = None
    stats: Stats | None = None
    note: str | None = None
    label: str | None = None


class NotMeasured(Exception):
    """Raised by a row's ``run`` when the measurement failed in a way that makes it n/a (the
    message is the note)."""


def _as_given(n: int, _quick: bool) -> int:
    return n


def _always(_ctx: BenchContext) -> str | None:
    return None


@dataclass(frozen=True)
class Measurement:
    """One row of the table, i.e. one key of the result.

    ``run(ctx, repeats)`` returns a list of timed repeats (their median is the value, in
    ``unit``), a derived number (or None), or a :class:`Reading`; it gets
    ``repeats(cfg.n, cfg.quick)`` repeats. It runs only when ``needs(ctx)`` is None, otherwise
    the key is n/a with that string as its note. Before it runs, the shared inputs named in
    ``uses`` are built and ``progress`` (if any) is announced; ``label`` and ``note`` may be
    callables of the context.
    """

    key: str
    group: str
    label: str | Callable[[BenchContext], str]
    run: Callable[[BenchContext, int], Any]
    unit: str = "ms"
    repeats: Callable[[int, bool], int] = _as_given
    needs: Callable[[BenchContext], str | None] = _always
    uses: tuple[str, ...] = ()
    progress: str | None = None
    device: str = "cpu"
    paper: float | None = None
    note: str | Callable[[BenchContext], str] = ""


# ---------------------------------------------------------------------------------- shared inputs

def _walk(cam: str):
    """A tracking-noise walk with the ``cam`` camera, long enough for the warm-up and repeats."""
    def build(ctx: BenchContext) -> timers.Walk:
        return timers.record_walk(ctx.level, CAMERAS[cam], TRACK_WARMUP + ctx.n, seed=ctx.seed)

    return (lambda _ctx: f"record a walk ({cam})"), build


def e2e_plan(ctx: BenchContext) -> tuple[int, tuple[str, ...]]:
    """``(tasks, estimators)`` of the end-to-end run: 2 tasks x ``ours`` quick, 6 tasks x
    ``ours, no-map, dynamics`` otherwise, unless configured; estimators that do not exist are
    left out."""
    cfg = ctx.cfg
    tasks = cfg.e2e_tasks if cfg.e2e_tasks is not None else (2 if cfg.quick else 6)
    est = cfg.e2e_estimators or (("ours",) if cfg.quick else ("ours", "no-map", "dynamics"))
    return tasks, tuple(e for e in est if e in ctx.available)


def _e2e_workers(ctx: BenchContext) -> int:
    from navbench.pipeline.executor import default_workers

    return ctx.cfg.workers or default_workers()


def _e2e_progress(ctx: BenchContext) -> str:
    tasks, est = e2e_plan(ctx)
    return f"end to end ({tasks} tasks x {len(est)} estimators, {_e2e_workers(ctx)} workers)"


def _e2e_run(ctx: BenchContext, camera: str = "half", options: dict | None = None,
             episode: dict | None = None) -> timers.Throughput:
    tasks, est = e2e_plan(ctx)
    return timers.time_navigation(Path(ctx.level_file), ctx.vmap,
                                  timers.bench_tasks(ctx.level, ctx.vmap, tasks, ctx.seed + 1),
                                  est, _e2e_workers(ctx), camera=camera, noise="mid", seed=ctx.seed,
                                  estimator_options=options, episode=episode)


def _e2e_run_version(ctx: BenchContext, version: str) -> timers.Throughput:
    """The paper-camera end-to-end run with ``ours`` at ``reference_scale`` 0.5 under
    ``version``'s settings."""
    return _e2e_run(ctx, "paper", *paper_levers(version))


def _versus_ratio(ctx: BenchContext, _n: int) -> Reading:
    v1, v2 = ctx.value("e2e_episodes_per_min_paper_ref05"), ctx.value(f"e2e_episodes_per_min_paper_ref05{_VS}")
    if not v1 or not v2:
        return Reading(value=None, note="needs both end-to-end rows")
    return Reading(value=v2 / v1, note=f"{v2:.1f} / {v1:.1f} episodes a minute, the same tasks, workers "
                                       f"and machine in this bench run")


#: Inputs that several rows use, built once on first use: name -> (progress label, builder).
SHARED: dict[str, tuple[Callable[[BenchContext], str], Callable[[BenchContext], Any]]] = {
    **{f"walk_{cam}": _walk(cam) for cam in CAMERA_NAMES},
    "e2e": (_e2e_progress, _e2e_run),
    "e2e_paper": (lambda ctx: _e2e_progress(ctx) + ", paper camera", lambda ctx: _e2e_run(ctx, "paper")),
    # the paper profile's ours (reference_scale 0.5)
    "e2e_paper_ref05": (lambda ctx: _e2e_progress(ctx) + ", paper camera, ours reference_scale 0.5",
                        lambda ctx: _e2e_run(ctx, "paper", {"ours": REF05})),
    # the same under VERSUS's settings (its estimator options and the camera's texture mode)
    f"e2e_paper_ref05{_VS}": (lambda ctx: _e2e_progress(ctx) + f", paper camera, ours reference_scale 0.5, {VERSUS}",
                           lambda ctx: _e2e_run_version(ctx, VERSUS)),
}


# ---------------------------------------------------------------------------------- conditions

def _cuda_why(ctx: BenchContext) -> str | None:
    if ctx.use_cuda:
        return None
    return "no CUDA device" if ctx.cfg.cuda is None or ctx.cfg.cuda else "CUDA disabled"


def _estimator_why(name: str, why: str) -> Callable[[BenchContext], str | None]:
    return lambda ctx: None if name in ctx.available else why


def _e2e_why(ctx: BenchContext) -> str | None:
    tasks, est = e2e_plan(ctx)
    if tasks == 0:
        return "disabled (0 tasks)"
    if not est:
        return "no estimator available"
    if ctx.level_file is None:
        return "the level is not a committed level file"
    return None


def _ratio_why(cam: str) -> Callable[[BenchContext], str | None]:
    def why(ctx: BenchContext) -> str | None:
        if ctx.value(f"track_ms_emission_{cam}") is None or ctx.value(f"track_ms_ours_adam_{cam}") is None:
            return "needs both the emission and the ours-Adam step"
        return None

    return why


# ---------------------------------------------------------------------------------- what rows run

def _fit_repeats(n: int, quick: bool) -> int:
    """Blocks of 10 fit steps: at most 3 in a quick run (a block is 10 steps)."""
    return min(n, 3) if quick else n


def _on_cuda(run: Callable[[BenchContext, int], Any]) -> Callable[[BenchContext, int], Any]:
    """``run``, with a failing device path reported as n/a (the run goes on)."""
    def guarded(ctx: BenchContext, n: int) -> Any:
        try:
            return run(ctx, n)
        except RuntimeError as e:
            raise NotMeasured(f"CUDA run failed: {str(e).splitlines()[0][:160]}") from e

    return guarded


def _fit_10k(suffix: str) -> Callable[[BenchContext, int], float | None]:
    def run(ctx: BenchContext, _n: int) -> float | None:
        med = ctx.value("fit_step_ms" + suffix)
        return None if med is None else med * FIT_STEPS / 1000.0

    return run


def _fit_note(_ctx: BenchContext) -> str:
    from navbench.worldmodel.fit import FitConfig

    return (f"fit_map itself on the CPU path (optimizer {FitConfig().optimizer!r}, default "
            "FitConfig): mean step time of each block of 10 steps after a 10-step warm-up, "
            "the first steps of a fit from the paper's initialisation")


def _track(cam: str, part: str, name: str, options: dict, label: str) -> Callable[[BenchContext, int], Reading]:
    """One ``estimator.update`` along the ``cam`` walk. A quick run times the emission update
    with 10 of the paper's 100 Adam steps (each step renders and back-propagates the same 1000
    pixels; an update has no other work) and scales it to 100."""
    def run(ctx: BenchContext, n: int) -> Reading:
        opts, scale, note = options, 1.0, None
        if name == "emission" and ctx.quick:
            opts = {**options, "steps": QUICK_EMISSION_STEPS}
            scale = EMISSION_STEPS / QUICK_EMISSION_STEPS
            note = (f"quick: measured with {QUICK_EMISSION_STEPS} Adam steps x 1000 px, "
                    f"scaled x{scale:g} to the paper's {EMISSION_STEPS}")
        shown = None
        if part == "ours":
            from navbench.track.ours import TrackerConfig

            shown = f"track {label} = {TrackerConfig().optimizer}, {cam}"
        times = timers.time_tracking(ctx.use(f"walk_{cam}"), ctx.vmap, CAMERAS[cam], name, opts, n,
                                     1 if name == "emission" else TRACK_WARMUP, ctx.seed, ctx.budget)
        return Reading(times=[scale * t for t in times], note=note, label=shown)

    return run


def _texture_ratio(cam: str) -> Callable[[BenchContext, int], Reading]:
    """Frame time of the procedural texture over the texel tables' (``texture="table"``), both
    (and the polynomial sine) rendered in turn on the same poses, each repeat 10 poses: the
    median of the per-repeat ratios, both medians in the note."""
    def run(ctx: BenchContext, n: int) -> Reading:
        import numpy as np

        from navbench.bench.core import stats

        t = timers.time_sim_frame_textures(ctx.level, CAMERAS[cam], max(n, 7), seed=ctx.seed)
        proc, tab, poly = (np.asarray(t[m]) for m in ("procedural", "table", "polynomial"))
        ratio = proc / tab
        return Reading(value=float(np.median(ratio)), stats=stats(ratio),
                       note=(f"interleaved, {len(ratio)} repeats of 10 poses: procedural "
                             f"{np.median(proc):.2f} ms, table {np.median(tab):.2f} ms, polynomial "
                             f"{np.median(poly):.2f} ms (medians); procedural / polynomial "
                             f"{np.median(proc / poly):.2f}x"))

    return run


def _ratio(cam: str) -> Callable[[BenchContext, int], float]:
    return lambda ctx, _n: ctx.value(f"track_ms_emission_{cam}") / ctx.value(f"track_ms_ours_adam_{cam}")


def _hz(cam: str) -> Callable[[BenchContext, int], Reading]:
    """Steps per second from the control step's times: 1000 / ms, quartiles likewise."""
    def run(ctx: BenchContext, _n: int) -> Reading:
        s = ctx.metrics[f"control_step_ms_{cam}"].stats
        if s is None or not s.n:
            return Reading()
        hz = Stats(s.n, 1000.0 / s.median, 1000.0 / s.q3, 1000.0 / s.q1, 1000.0 / s.max, 1000.0 / s.min)
        return Reading(value=hz.median, stats=hz)

    return run


def _e2e(per: str, camera: str = "half", shared: str | None = None,
         opts: str = "") -> Callable[[BenchContext, int], Reading]:
    """Episodes per minute or steps per second of the shared end-to-end run (``camera``; ``shared``:
    another shared run of that camera, its estimator options said by ``opts``)."""
    def run(ctx: BenchContext, _n: int) -> Reading:
        tp = ctx.use(shared or ("e2e" if camera == "half" else f"e2e_{camera}"))
        tasks, est = e2e_plan(ctx)
        note = (f"run-navigation stage: {tp.episodes} episodes ({tasks} tasks x "
                f"{', '.join(est)}{opts}), {tp.steps} steps, mid noise, {camera} camera, {tp.workers} local "
                f"workers, {tp.seconds:.1f} s after a warm-up pass")
        if per == "episodes":
            at = "" if camera == "half" else f", {camera} camera{opts}"
            return Reading(value=60.0 * tp.episodes / tp.seconds if tp.episodes else None, note=note,
                           label=f"episodes per minute ({tp.workers} workers{at})")
        return Reading(value=tp.steps / tp.seconds if tp.steps else None, note=note,
                       label=f"episode steps per second ({tp.workers} workers)")

    return run


# ---------------------------------------------------------------------------------- the table

_DIFF_NOTE = ("render_rays (numba crossing search + autograd at the bracket), Delta 0.1 m, "
              "n 200, paper-camera pixels")
_TRACK_NOTE = "estimator.update incl. the reference render, tracking-noise walk"
_CONTROL_NOTE = ("run_episode per-step sum: controller + simulator step with its RGB-D frame (only "
                 "the pixels ours reads) + tracking with the map render + A* when (re)planning; mid noise")
_OURS_NA = "estimator 'ours' not available"
_FIT_CUDA = "fit-map step, 25x200 px [CUDA]"
_DIFF_CUDA = "diff. render fwd, 5000 rays [CUDA]"

TABLE: tuple[Measurement, ...] = (
    # simulator: one RGB-D frame of the ray-cast camera, one dynamics + collision step
    *(Measurement(f"sim_frame_ms_{cam}", "simulator", f"sim RGB-D frame, {cam}",
                  lambda ctx, n, cam=cam: timers.time_sim_frame(ctx.level, CAMERAS[cam], n, seed=ctx.seed),
                  progress=f"simulator frame ({cam})") for cam in CAMERA_NAMES),
    Measurement("sim_frame_ms_paper_ours", "simulator", "sim frame, paper, ours' pixels",
                lambda ctx, n: timers.time_sim_frame(ctx.level, CAMERAS["paper"], n, seed=ctx.seed,
                                                     pixels_of="ours"),
                progress="simulator frame (paper, ours' pixels)",
                note="only the 3000 pixels ours reads (observed_pixels): the frame ours gets in an episode"),
    Measurement("sim_step_ms", "simulator", "sim dynamics + collision step",
                lambda ctx, n: timers.time_sim_step(ctx.level, n, seed=ctx.seed),
                repeats=lambda n, _quick: 50 * n, progress="simulator step"),
    # world model: the fast map render, the differentiable render and the fit step
    *(Measurement(f"render_ms_{cam}", "world model", f"map render (numba), {cam}",
                  lambda ctx, n, cam=cam: timers.time_map_render(ctx.level, ctx.vmap, CAMERAS[cam], n,
                                                                 seed=ctx.seed, budget_s=ctx.budget),
                  progress=f"map render ({cam})",
                  paper=PAPER_FIGURES["voxel_render_ms"] if cam == "paper" else None,
                  note=lambda ctx: (f"ray samples every {ctx.step:.4g} m (the map's Delta), "
                                    f"{int(round(20.0 / ctx.step))} per ray"))
      for cam in CAMERA_NAMES),
    *(Measurement(f"diffrender_ms_{rays}", "world model",
                  f"diff. render fwd, {rays} rays" + (" (25x200)" if rays == 5000 else ""),
                  lambda ctx, n, rays=rays: timers.time_diff_render(ctx.level, ctx.vmap, rays, n, seed=ctx.seed,
                                                                    budget_s=ctx.budget),
                  progress=f"differentiable render ({rays} rays)", note=_DIFF_NOTE)
      for rays in (5000, 1000)),
    Measurement("fit_step_ms", "world model", "fit-map step (25x200 px, fwd+bwd+Adam)",
                lambda ctx, n: timers.time_fit_step(ctx.level, n, seed=ctx.seed, device="cpu"),
                repeats=_fit_repeats, progress="fit-map step", note=_fit_note),
    Measurement("fit_10k_steps_s", "world model", "fit-map 10 000 steps", _fit_10k(""), unit="s",
                note="EXTRAPOLATED: 10 000 x the median fit-map step time"),
    Measurement("diffrender_ms_5000_cuda", "world model", _DIFF_CUDA,
                _on_cuda(lambda ctx, n: timers.time_diff_render(ctx.level, ctx.vmap, 5000, n, seed=ctx.seed,
                                                                device="cuda", budget_s=ctx.budget)),
                needs=_cuda_why, progress=_DIFF_CUDA, device="cuda:0",
                note="render_rays_torch (crossing search over every sample on the GPU, autograd at "
                     "the bracket) on cuda:0, the fit's device path"),
    Measurement("fit_step_ms_cuda", "world model", _FIT_CUDA,
                _on_cuda(lambda ctx, n: timers.time_fit_step(ctx.level, n, seed=ctx.seed, device="cuda")),
                repeats=_fit_repeats, needs=_cuda_why, progress=_FIT_CUDA, device="cuda:0",
                note="fit_map itself with device='cuda' (render_rays_torch, free-space term, masked "
                     "lazy Adam on cuda:0); blocks of 10 steps as the CPU row"),
    Measurement("fit_10k_steps_s_cuda", "world model", "fit-map 10 000 steps [CUDA]", _fit_10k("_cuda"),
                unit="s", device="cuda:0", note="EXTRAPOLATED: 10 000 x the median fit-map step time"),
    # planning
    Measurement("plan_ms", "planning", lambda ctx: f"A* plan across {ctx.level.name}",
                lambda ctx, n: timers.time_plan(ctx.level, ctx.vmap, n, seed=ctx.seed, budget_s=ctx.budget),
                progress="A* plan",
                note="the farthest seeded free-point pair that needs A* (no straight-line shortcut), "
                     "band slice of the map, distance transform precomputed"),
    # tracking: one update of each estimator along a recorded walk, and the equal-budget ratio
    *(Measurement(f"track_ms_{part}_{cam}", "tracking", f"track {label}, {cam}",
                  _track(cam, part, name, options, label),
                  needs=_estimator_why(name, f"estimator {name!r} not available yet"),
                  uses=(f"walk_{cam}",), progress=f"tracking {part} ({cam})",
                  paper=PAPER_FIGURES["ours_track_ms"] if part == "ours" else
                  PAPER_FIGURES["emission_track_ms"] if part == "emission" else None,
                  note=_TRACK_NOTE)
      for cam in CAMERA_NAMES for part, name, options, label in TRACKERS),
    *(Measurement(f"emission_ours_ratio_{cam}", "tracking", f"emission / ours-Adam step, {cam}",
                  _ratio(cam), unit="x", needs=_ratio_why(cam),
                  paper=PAPER_FIGURES["emission_track_ms"] / PAPER_FIGURES["ours_track_ms"],
                  note="equal pixel budget: both Adam, 100 steps x 1000 pixels")
      for cam in CAMERA_NAMES),
    # the full control step of an episode, and its rate
    *(row for cam in CAMERA_NAMES for row in (
        Measurement(f"control_step_ms_{cam}", "control", f"control step (ours), {cam}",
                    lambda ctx, n, cam=cam: timers.time_control_step(ctx.level, ctx.vmap, CAMERAS[cam], n,
                                                                     seed=ctx.seed, budget_s=ctx.budget),
                    repeats=lambda n, _quick: max(n, 10), needs=_estimator_why("ours", _OURS_NA),
                    progress=f"control step ({cam})", paper=PAPER_FIGURES["control_step_ms"],
                    note=_CONTROL_NOTE),
        Measurement(f"control_step_hz_{cam}", "control", f"control step rate (ours), {cam}", _hz(cam),
                    unit="Hz", needs=_estimator_why("ours", _OURS_NA), paper=PAPER_FIGURES["control_step_hz"],
                    note="1000 / step time (quartiles likewise)"))),
    # end to end: whole episodes through the pipeline's run-navigation stage
    Measurement("e2e_episodes_per_min", "end to end", "episodes per minute", _e2e("episodes"),
                unit="episodes/min", needs=_e2e_why),
    Measurement("e2e_steps_per_s", "end to end", "episode steps per second", _e2e("steps"),
                unit="steps/s", needs=_e2e_why),
    # issue #17: the agent's own step (the control step without the simulator's step and
    # camera), and whole episodes at the paper camera
    *(Measurement(f"agent_step_ms_{cam}", "control", f"agent step (ours, no simulator), {cam}",
                  lambda ctx, n, cam=cam: timers.time_control_step(ctx.level, ctx.vmap, CAMERAS[cam], n,
                                                                   seed=ctx.seed, budget_s=ctx.budget,
                                                                   exclude=("sim",)),
                  repeats=lambda n, _quick: max(n, 10), needs=_estimator_why("ours", _OURS_NA),
                  progress=f"agent step ({cam})",
                  note="run_episode per-step sum without the simulator: controller + tracking with the "
                       "map render + A* when (re)planning; mid noise") for cam in CAMERA_NAMES),
    Measurement("e2e_episodes_per_min_paper", "end to end", "episodes per minute, paper camera",
                _e2e("episodes", "paper"), unit="episodes/min", needs=_e2e_why),
    # issue 15: online mapping, one frame fused into the level's default grid
    *(Measurement(f"fusion_ms_{cam}", "world model", f"online fusion of one frame, {cam}",
                  lambda ctx, n, cam=cam: timers.time_fusion(ctx.use(f"walk_{cam}"), ctx.level, CAMERAS[cam],
                                                             n, TRACK_WARMUP, ctx.budget),
                  uses=(f"walk_{cam}",), progress=f"online fusion ({cam})",
                  note="fuse_frame (TSDF, navbench.worldmodel.fusion) at the true pose along the "
                       "tracking walk, 200 x 200 x 20 grid of the level; issue 15 target <= 10 ms "
                       "at the half camera") for cam in CAMERA_NAMES),
    # issue #17, part 2: the same steps with ours' option reference_scale = 0.5 (the reference
    # rendered at 160 x 120; not the default: it changes results, docs/notebook/speed.md)
    *(Measurement(f"{what}_ms_paper_ref05", "control", f"{label} (ours, reference_scale 0.5), paper",
                  lambda ctx, n, ex=ex: timers.time_control_step(
                      ctx.level, ctx.vmap, CAMERAS["paper"], n, seed=ctx.seed, budget_s=ctx.budget,
                      exclude=ex, options=REF05),
                  repeats=lambda n, _quick: max(n, 10), needs=_estimator_why("ours", _OURS_NA),
                  progress=f"{label} (paper, reference_scale 0.5)",
                  note="as the row without _ref05, ours with reference_scale = 0.5")
      for what, label, ex in (("agent_step", "agent step", ("sim",)), ("control_step", "control step", ()))),
    # the paper profile's setting of ours (reference_scale = 0.5, docs/notebook/speed.md)
    Measurement("e2e_episodes_per_min_paper_ref05", "end to end",
                "episodes per minute, paper camera, ours reference_scale 0.5",
                _e2e("episodes", "paper", "e2e_paper_ref05", ", ours reference_scale 0.5"), unit="episodes/min",
                needs=_e2e_why,
                uses=("e2e_paper_ref05",)),
    # issue 36: the camera's texture modes, interleaved in one process (navbench.sim.texels)
    *(Measurement(f"sim_frame_texture_ratio_{cam}", "simulator", f"sim frame procedural / table texture, {cam}",
                  _texture_ratio(cam), unit="x", progress=f"simulator frame, texture modes ({cam})")
      for cam in CAMERA_NAMES),
    # issue 36: the version under test (VERSUS) beside navbench-1 in the same run (its levers:
    # navbench.benchmark)
    *(Measurement(f"{what}_ms_paper_ref05{_VS}", "control", f"{label} (ours, reference_scale 0.5), paper, {VERSUS}",
                  lambda ctx, n, ex=ex: timers.time_control_step(
                      ctx.level, ctx.vmap, CAMERAS["paper"], n, seed=ctx.seed, budget_s=ctx.budget,
                      exclude=ex, **_versus_ours()),
                  repeats=lambda n, _quick: max(n, 10), needs=_estimator_why("ours", _OURS_NA),
                  progress=f"{label} (paper, reference_scale 0.5, {VERSUS})",
                  note=f"as the _ref05 row, with {VERSUS}'s settings (ours' options and the camera's texture mode)")
      for what, label, ex in (("agent_step", "agent step", ("sim",)), ("control_step", "control step", ()))),
    Measurement(f"e2e_episodes_per_min_paper_ref05{_VS}", "end to end",
                f"episodes per minute, paper camera, ours reference_scale 0.5, {VERSUS}",
                _e2e("episodes", "paper", f"e2e_paper_ref05{_VS}", f", ours reference_scale 0.5, {VERSUS}"),
                unit="episodes/min", needs=_e2e_why, uses=(f"e2e_paper_ref05{_VS}",)),
    Measurement(f"e2e{_VS}_over_v1_paper_ref05", "end to end", f"episodes per minute, {VERSUS} / navbench-1",
                _versus_ratio, unit="x", needs=_e2e_why),
)


def metric_keys() -> list[str]:
    """Every flat key of :func:`~navbench.bench.run.run_bench`'s result that holds a measurement:
    the keys of :data:`TABLE`, in its order."""
    return [row.key for row in TABLE]


def _check_table() -> None:
    keys = metric_keys()
    if len(set(keys)) != len(keys):
        raise AssertionError(f"duplicate keys in the bench table: {keys}")
    missing = [t.key for t in TARGETS if t.key not in keys] + \
        [u for row in TABLE for u in row.uses if u not in SHARED]
    if missing:
        raise AssertionError(f"the bench table lacks {missing}")


_check_table()
