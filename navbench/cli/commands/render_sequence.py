"""``navbench render-sequence``: a continuous walk on a level rendered as a TUM RGB-D sequence."""

from __future__ import annotations

from pathlib import Path

import typer

from navbench.cli._common import console


def register(app: typer.Typer) -> None:
    @app.command("render-sequence")
    def render_sequence(
        level: str = typer.Argument(..., metavar="LEVEL", help="Level name (levels/NAME.json, or a benchmark level) "
                                    "or path to a level file."),
        out: Path = typer.Argument(..., metavar="OUT", help="Output folder (new or empty)."),
        frames: int = typer.Option(300, "--frames", min=2, max=100_000, help="Frames of the sequence."),
        walk: str = typer.Option("planner", "--walk", help="planner (the shortest paths between "
                                 "sampled tasks, driven by the simulator without noise) or random "
                                 "(the tracking study's random walk, with its actuation noise)."),
        noise: str = typer.Option(None, "--noise", help="Also write odometry.txt: the ground truth's "
                                  "increments with this noise level (none, low, mid, high, tracking), "
                                  "as track-sequence --odometry gt+NOISE draws them. Default: no "
                                  "odometry file."),
        camera: str = typer.Option("half", "--camera", help="half (160x120) or paper (320x240)."),
        seed: int = typer.Option(0, "--seed", min=0, max=2**63 - 1, help="Seed of the walk (its tasks or random "
                                 "waypoints) and of the odometry noise."),
        sim: str = typer.Option("pymunk", "--sim", help="The frames' simulator: pymunk (the exact "
                                "ray-cast camera) or vizdoom (the paper's engine; its projection is "
                                "written to intrinsics.json, its pose to groundtruth.txt; needs pip "
                                "install 'navbench\\[vizdoom]')."),
    ):
        """Render a continuous walk as TUM RGB-D: rgb/, depth/ (16-bit, m x 5000), rgb.txt,
        depth.txt, groundtruth.txt, intrinsics.json, and with --noise odometry.txt.

        The sequence is what track-sequence and fit-map --views read, so an own-data loop needs
        no Python: render-sequence house-1 seq --noise mid; fit-map --views seq; track-sequence
        seq --map KEY --odometry seq/odometry.txt.
        """
        import time

        import numpy as np

        from navbench.cli.commands._pipeline_ui import PipelineUI
        from navbench.errors import ConfigError
        from navbench.geometry import CAMERA_NAMES, camera_by_name
        from navbench.names import did_you_mean
        from navbench.outpath import check_output
        from navbench.pipeline.run import stage_context
        from navbench.pipeline.stages.level import load_level_ref
        from navbench.pipeline.stages.track_eval import study_level
        from navbench.sim.dynamics import NOISE_LEVELS
        from navbench.track.sequence import WALKS, render_walk
        from navbench.worldmodel.tum import export_views

        if walk not in WALKS:
            raise ConfigError(f"--walk {walk}: unknown walk{did_you_mean(walk, WALKS)}; choose one of {', '.join(WALKS)}")
        if noise is not None and noise not in NOISE_LEVELS:
            raise ConfigError(f"--noise {noise}: unknown noise level{did_you_mean(noise, NOISE_LEVELS)}; "
                              f"choose one of {', '.join(NOISE_LEVELS)}")
        if camera not in CAMERA_NAMES:
            raise ConfigError(f"--camera {camera}: unknown camera{did_you_mean(camera, CAMERA_NAMES)}; "
                              f"choose one of {', '.join(CAMERA_NAMES)}")
        from navbench.sim.backends import require_sim

        require_sim(sim)
        check_output(out, "OUT", kind="dir", example="seq")
        if out.is_dir() and any(out.iterdir()):  # never mixed with, or written over, other files
            raise ConfigError(f"OUT {out}: is not empty; render into a new or empty folder")
        intrinsics = camera_by_name(camera)
        from navbench.worldmodel.views import check_views_memory

        check_views_memory(frames, intrinsics, "--frames")
        t0 = time.perf_counter()
        with PipelineUI() as ui:
            ref = study_level(stage_context(ui), level)
        lv = load_level_ref(ref)
        views = render_walk(lv, frames, intrinsics, seed=seed, walk=walk,
                            noise="none" if walk == "planner" else "tracking", sim=sim)
        export_views(views, out)
        wrote = "rgb/, depth/, rgb.txt, depth.txt, groundtruth.txt, intrinsics.json"
        if noise is not None:
            from navbench.pipeline.stages.sequence import ODOMETRY_STREAM
            from navbench.track.odometry import integrate, noisy_increments, relative_increments
            from navbench.worldmodel.tumtraj import write_trajectory

            rng = np.random.default_rng([int(seed), ODOMETRY_STREAM])
            inc = noisy_increments(relative_increments(views.poses), NOISE_LEVELS[noise], rng)
            odo = integrate(views.poses[0], inc)
            write_trajectory(out / "odometry.txt", [f"{n * 0.05:.6f}" for n in range(len(odo))], odo,
                             views.camera_height)
            wrote += f", odometry.txt ({noise} noise)"
        step = np.diff(views.poses[:, :2], axis=0)
        console.print(f"rendered {frames} {camera} frames of {lv.name} ({walk} walk, seed {seed}, "
                      f"{float(np.hypot(step[:, 0], step[:, 1]).sum()):.1f} m) in "
                      f"{time.perf_counter() - t0:.1f} s -> {out}: {wrote}", markup=False, highlight=False)
