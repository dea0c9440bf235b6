"""``navbench track-eval``: the tracking study (appendix E) on one level."""

from __future__ import annotations

import typer
from rich.markup import escape

from navbench.cli._common import console, parse_estimator_options, parse_list, print_json
from navbench.cli._help import DB_HELP, SET_HELP, SIM_HELP, default, profile_help
from navbench.pipeline.profiles import MAX_SEEDS, MAX_TASKS  # light


def register(app: typer.Typer) -> None:
    @app.command("track-eval")
    def track_eval(
        level: str = typer.Argument(..., help="Level name (levels/NAME.json) or path to a level file."),
        trajectories: int = typer.Option(None, "--trajectories", min=1, max=MAX_TASKS,
                                         help="Recorded trajectories \\[default: 3000 / --steps, "
                                         "at most 30: 30 x 100 steps, 3 x 1000 steps]."),
        seeds: int = typer.Option(1, "--seeds", min=1, max=MAX_SEEDS, help="Estimator seeds per trajectory."),
        estimators: str = typer.Option("ours,emission,no-map,dynamics,gt", "--estimators",
                                       help="Comma-separated estimator names."),
        steps: int = typer.Option(100, "--steps", min=1, max=1_000_000, help="Controls per trajectory."),
        camera: str = typer.Option("half", "--camera", help="half or paper."),
        map_: str = typer.Option("fit", "--map", help="fit: the profile's fitted world model (built "
                                 "if missing, as in the paper's study); true: the voxelised true "
                                 "geometry (an upper bound); online: no prior map, the map-based "
                                 "estimators track and map together from the start pose; or a map "
                                 "file (map.npz format)."),
        profile: str = typer.Option(None, "--profile", help=profile_help("Profile whose fit settings "
                                                                          "build the map with --map fit")),
        sets: list[str] = typer.Option(None, "--set", metavar="KEY=VALUE", help=SET_HELP),
        benchmark_version: str = typer.Option(None, "--benchmark-version", metavar="NAME",
                                              help="Benchmark version of the study: its frames' "
                                              "textures and its trackers' options (as run-navigation's "
                                              "episodes under it), and with --map fit the map's views "
                                              "and fit; --option wins over the version's tracker "
                                              "options " + default("with --map fit the profile's "
                                                                   "benchmark_version, else the "
                                                                   "current version") + ".",
                                              show_default=False),
        seed: int = typer.Option(0, "--seed", min=0, max=2**63 - 1, help="Trajectory recording seed."),
        noise: str = typer.Option("tracking", "--noise", help="Noise level of the recorded "
                                  "trajectories: tracking (the paper's study), none, low, mid, high."),
        kidnap_every: int = typer.Option(None, "--kidnap-every", help="Teleport the true pose to a "
                                         "random free pose every N >= 1 steps (seeded; the "
                                         "estimators are not told) \\[default: never]."),
        odometry: str = typer.Option(None, "--odometry", help="world: replay the recorded controls "
                                     "(absolute directions set from the true heading); body: in each "
                                     "estimator's own frame, as a robot's odometry \\[default: world, "
                                     "body with --kidnap-every]."),
        collisions: str = typer.Option("freeze", "--collisions", help="After a collision while "
                                       "recording: freeze (appendix D: no further movement for the "
                                       "rest of the trajectory) or stop (the colliding step does not "
                                       "move the robot and its odometry reads no motion; it goes on "
                                       "to a new waypoint)."),
        option: list[str] = typer.Option([], "--option", "-o", help="Estimator option "
                                         "ESTIMATOR.KEY=VALUE (repeatable), e.g. ours.optimizer=adam, "
                                         "emission.steps=100."),
        emission_trajectories: int = typer.Option(None, "--emission-trajectories", min=1, max=MAX_TASKS,
                                                  help="Replay the slow emission tracker on the first "
                                                  "this-many trajectories only \\[default: 1000 / "
                                                  "--steps, at most 10]."),
        paper_budget: bool = typer.Option(False, "--paper-budget", help="Emission tracker with the "
                                          "paper's budget (100 steps x 1000 pixels) instead of the "
                                          "study's default (20 x 500)."),
        sim: str = typer.Option(None, "--sim", help=SIM_HELP + " \\[default: the profile's sim with "
                                "--map fit, else pymunk]."),
        json_out: bool = typer.Option(False, "--json", help="Print one JSON object keyed by estimator."),
        db: str = typer.Option(None, "--db", help=DB_HELP),
        no_store: bool = typer.Option(False, "--no-store", help="Do not store the per-trajectory "
                                      "rows in the results database."),
    ):
        """Record trajectories once (tracking-study noise), replay every estimator on them.

        Reports per estimator the location RMSE (m) and orientation RMSE (deg) over
        trajectories and the per-step time (render + estimate, ms); --json prints one object
        keyed by estimator (plus "meta").
        """
        import time
        from contextlib import nullcontext

        from navbench.cli.commands._pipeline_ui import command_line, run_with_ui
        from navbench.pipeline.artifacts import load_study
        from navbench.pipeline.profiles import load_profile
        from navbench.pipeline.run import open_db, recorded_run, stage_context
        from navbench.pipeline.stages import study_level, study_map, track_eval_stage
        from navbench.track.study import STUDY_EMISSION_OPTIONS, TrackingStudyConfig, summarise

        names = tuple(parse_list(estimators))
        parsed_options = parse_estimator_options(option)
        _check_estimators(names, parsed_options)  # before the level is built or anything recorded
        if map_ == "online":
            from navbench.track.slam import check_online

            for n in names:
                check_online(n)
        from navbench.errors import ConfigError

        if sets and map_ != "fit":
            raise ConfigError(f"--set: changes the profile's map settings, which only --map fit reads (--map {map_})")
        from navbench.pipeline.overrides import apply_sets

        from navbench.pipeline.versioning import study_settings, with_version

        prof = None
        if map_ == "fit":  # the map's views and fit under the version, as `navbench all`'s
            prof = load_profile(profile)
            if benchmark_version is not None:
                prof = with_version(prof, benchmark_version, "command line", "--benchmark-version")
            prof = apply_sets(prof, sets)
            benchmark_version = prof.benchmark_version
        elif benchmark_version is None:
            from navbench.benchmark import BENCHMARK_VERSION

            benchmark_version = BENCHMARK_VERSION
        # the frames' texture and the trackers' options of the version (an unknown one: one line)
        texture, version_opts = study_settings(benchmark_version, names)
        from navbench.sim.backends import require_sim

        if sim is None:
            sim = prof.sim if prof is not None else "pymunk"
        require_sim(sim)  # a known name, and vizdoom installed: before anything is built
        if prof is not None:  # --map fit: the map of the same simulator's views
            from navbench.pipeline.profiles import override

            prof = override(prof, sim=sim)
        from navbench.errors import ConfigError
        from navbench.pipeline.profiles import NOISE_NAMES

        if kidnap_every is not None and kidnap_every < 1:
            raise ConfigError(f"--kidnap-every: expected a step count >= 1, got {kidnap_every}")
        kidnap_every = kidnap_every or 0
        if noise not in NOISE_NAMES:
            raise ConfigError(f"--noise: expected one of {', '.join(NOISE_NAMES)}, got {noise!r}")
        from navbench.geometry import camera_by_name
        from navbench.pipeline.stages.track_eval import check_map_spec

        camera_by_name(camera)  # before the level is recorded or a run row inserted
        check_map_spec(map_)
        if odometry is None:
            odometry = "body" if kidnap_every else "world"
        if trajectories is None:
            trajectories = default_trajectories(steps)
        if emission_trajectories is None:
            emission_trajectories = default_trajectories(steps, 1000, 10)
        opts = {"emission": {} if paper_budget else dict(STUDY_EMISSION_OPTIONS)}
        for name, o in version_opts.items():  # the version's, under what --option says
            opts.setdefault(name, {}).update(o)
        for name, o in parsed_options.items():
            opts.setdefault(name, {}).update(o)
        cfg = TrackingStudyConfig(trajectories=trajectories, seeds=seeds, steps=steps,
                                  estimators=names, camera=camera, seed=seed, noise=noise,
                                  estimator_options=opts,
                                  trajectory_limits={"emission": emission_trajectories},
                                  kidnap_every=kidnap_every, odometry=odometry, collisions=collisions,
                                  sim=sim, texture=texture, benchmark_version=benchmark_version)
        from navbench.track.registry import uses_map

        needs_map = any(uses_map(n) for n in names)
        t0 = time.perf_counter()

        def study(ui, rdb):
            """Run (or fetch) the study; with a database, as a recorded run that stores its rows."""
            ctx = stage_context(ui, rdb)
            level_ref = study_level(ctx, level, prof)
            vmap = study_map(ctx, map_, level_ref, prof, needs_map)
            config = {"level": level_ref.key, "map": vmap.key, "study": cfg}
            record = nullcontext() if rdb is None else recorded_run(
                rdb, "track-eval", command_line(), config, ctx, f"track-eval-{level_ref.name}", sim=sim,
                benchmark_version=benchmark_version)
            with record as run_id:
                ref = track_eval_stage(ctx, level_ref, vmap, cfg)
                res = load_study(ref.path)
                stored = None if rdb is None else _store(rdb, run_id, res, ref.key, vmap.key)
            return level_ref, vmap, ref, res, stored

        def body(ui):
            with (nullcontext() if no_store else open_db(db)) as rdb:
                return study(ui, rdb)

        level_ref, vmap, ref, res, stored = run_with_ui(body, json_mode=json_out)
        lvl_name = level_ref.name
        summary = summarise(res)
        raw = raw_odometry_summary(res)
        line = study_version_line(cfg, version_opts, prof)
        if json_out:
            meta = {"level": lvl_name, "map": map_, "map_key": vmap.key, "study_key": ref.key,
                    "cached": ref.cached, "camera": camera, "trajectories": trajectories,
                    "steps": steps, "seeds": seeds, "options": opts, "noise": noise,
                    "odometry": odometry, "kidnap_every": kidnap_every, "raw_odometry": raw,
                    "collisions": collisions, "sim": sim, "benchmark_version": benchmark_version,
                    "version_line": line,
                    "collided_trajectories": int(sum(res["trajectories"]["collided"])),
                    "trajectory_limits": cfg.trajectory_limits,
                    "wall_s": round(time.perf_counter() - t0, 3), "stored": stored,
                    "health_thresholds": ref.meta.get("health_thresholds", {})}
            print_json(_finite({**summary, "meta": meta}))
            return
        from rich.table import Table

        console.print(line, markup=False)
        t = Table(title=escape(f"tracking on {lvl_name} ({trajectories} x {steps} steps, noise {noise}, "
                               f"odometry {odometry}, map {map_}, camera {camera}"
                               + (f", sim {sim}" if sim != "pymunk" else "")
                               + (f", kidnap every {kidnap_every}" if kidnap_every else "") + ")"))
        for col in ("estimator", "runs", "ATE median (m)", "ATE p99 (m)",
                    "< 0.1 m", "rot RMSE median (deg)", "step median (ms)"):
            t.add_column(col, justify="left" if col == "estimator" else "right")
        for name, s in summary.items():
            t.add_row(escape(name), str(s["runs"]), f"{s['loc_rmse_m_median']:.4f}", f"{s['loc_rmse_m_p99']:.4f}",
                      f"{100 * s['frac_loc_rmse_below_0_1m']:.0f} %", f"{s['rot_rmse_deg_median']:.3f}",
                      f"{s['step_ms_median']:.2f}")
        console.print(t)
        console.print(f"ATE: translation RMSE without alignment (TUM / evo; the location RMSE). "
                      f"Raw odometry (dead reckoning of the body-frame controls): ATE median "
                      f"{raw['ate_m_median']:.4f} m, mean {raw['ate_m_mean']:.4f} m.", markup=False)
        _print_health(summary)
        for name, th in ref.meta.get("health_thresholds", {}).items():
            console.print(f"{name}: health_min_inliers=auto calibrated to {th:.3f} on the map's "
                          f"views", markup=False)
        if stored:
            console.print(f"stored {stored['rows']} new tracking rows (run {stored['run_id']}, "
                          f"study {stored['study_key'][:12]}) in {stored['db']}", markup=False)
        console.print(f"took {time.perf_counter() - t0:.1f} s"
                      + (" (cached study: step times are those of the run that computed it)"
                         if ref.cached else ""), markup=False)


def study_version_line(cfg, version_opts: dict[str, dict], prof=None) -> str:
    """One line naming the study's benchmark version and where it departs from it: a tracker
    option ``--option`` set to another value than the version's, and with ``--map fit`` the
    map profile's departures (:func:`navbench.pipeline.versioning.version_line`)."""
    from navbench.config import canonical_json
    from navbench.pipeline.versioning import departure_line, departures

    gone = {} if prof is None else departures(prof)
    for name, fixed in version_opts.items():
        have = cfg.estimator_options.get(name, {})
        gone.update({f"{name}.{k}": (have[k], v) for k, v in fixed.items()
                     if canonical_json(have.get(k)) != canonical_json(v)})
    return departure_line(cfg.benchmark_version, gone)


def _finite(obj):
    """``obj`` with every float nan replaced by None (strict JSON)."""
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, float) and obj != obj:
        return None
    return obj


def default_trajectories(steps: int, budget: int = 3000, most: int = 30) -> int:
    """A default trajectory count: ``budget`` steps in all (the default study's 30 x 100; its
    emission tracker's 10 x 100), at least 1 and at most ``most``, so that any ``--steps``
    keeps the default run time."""
    return max(1, min(most, round(budget / max(int(steps), 1))))


def raw_odometry_summary(res: dict) -> dict:
    """Median and mean raw-odometry ATE (m) of the study's trajectories (nan for a study
    stored before it was recorded)."""
    import numpy as np

    raw = res["trajectories"].get("raw_odom_ate_m")
    if raw is None or not len(raw):
        return {"ate_m_median": float("nan"), "ate_m_mean": float("nan")}
    return {"ate_m_median": float(np.median(raw)), "ate_m_mean": float(np.mean(raw))}


def _print_health(summary: dict) -> None:
    """The kidnap / health table, for the estimators that have such figures."""
    from rich.table import Table

    rows = {n: s for n, s in summary.items() if "kidnaps" in s or "alarms_per_step" in s}
    if not rows:
        return
    t = Table(title="kidnapped robot (recovered: location < 0.25 m and heading < 10 deg within "
                    "5 steps; false alarm: an alarm at a pose within that tolerance; per step)")
    cols = ("estimator", "kidnaps", "detected", "recovered <= 5 steps", "steps to recover (median)",
            "alarms per step", "false alarms per step", "runs with a false alarm", "relocalisations")
    for col in cols:
        t.add_column(col, justify="left" if col == "estimator" else "right")

    def pct(v):
        return "-" if v is None or v != v else f"{100 * v:.1f} %"

    for name, s in rows.items():
        steps = s.get("recover_steps_median")
        t.add_row(escape(name), str(s.get("kidnaps", "-")), pct(s.get("detected_frac")),
                  pct(s.get("recovered_frac")), "-" if steps is None or steps != steps else f"{steps:.1f}",
                  "-" if "alarms_per_step" not in s else f"{100 * s['alarms_per_step']:.2f} %",
                  "-" if "false_alarms_per_step" not in s else f"{100 * s['false_alarms_per_step']:.2f} %",
                  pct(s.get("false_alarm_trajectories_frac")), str(s.get("relocalizations", "-")))
    console.print(t)


def _check_estimators(names: tuple[str, ...], options: dict[str, dict]) -> None:
    """``--estimators``: at least one, each known (built-in or plugin) and loadable;
    ``--option``: only for known estimators."""
    from navbench.errors import ConfigError
    from navbench.track.registry import check_estimator_names, known_estimators

    if not names:
        raise ConfigError("--estimators: expected at least one estimator name "
                          f"(known: {', '.join(known_estimators())})")
    check_estimator_names(names, "--estimators")
    check_estimator_names(options, "--option")
    from navbench.pipeline.checks import check_estimator_options

    # values checked now, not after views and a map fit: the checks of a profile's
    # [navigation.options.<estimator>] (types, ranges, the estimator's own)
    check_estimator_options(options, "--option")


def _store(rdb, run_id: int, res: dict, study_key: str, map_key: str) -> dict:
    """Store one row per (estimator, trajectory, seed) in the results database, under the
    study's key (the track-eval artifact's: it hashes the study config, the level's content key
    and the map's key), so a rerun of the same study adds no duplicate rows."""
    from navbench.track.study import tracking_rows

    n = rdb.add_tracking_rows(run_id, tracking_rows(res, study_key, map_key))
    return {"run_id": run_id, "study_key": study_key, "rows": n, "db": rdb.display_url}
