"""``navbench import-views``: a TUM RGB-D directory -> a navbench views artifact."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from navbench.cli._common import console
from navbench.cli._help import default


def _check_options(fx, fy, cx, cy, camera_height, depth_scale, max_dt) -> None:
    """Refuse option values no camera or sequence can have, naming the option (ConfigError).

    Focal lengths, camera height and depth scale must be positive and finite, ``--max-dt``
    finite and >= 0; ``--fy``/``--cx``/``--cy`` refine ``--fx`` and mean nothing without it
    (the intrinsics then come whole from intrinsics.json). The principal point is checked
    against the image size once that is known.
    """
    from navbench.errors import ConfigError

    for name, v in (("--fx", fx), ("--fy", fy), ("--camera-height", camera_height),
                    ("--depth-scale", depth_scale)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise ConfigError(f"{name} must be a positive finite number, got {v:g}")
    for name, v in (("--cx", cx), ("--cy", cy)):
        if v is not None and not math.isfinite(v):
            raise ConfigError(f"{name} must be a finite number (px), got {v:g}")
    if not (math.isfinite(max_dt) and max_dt >= 0):
        raise ConfigError(f"--max-dt must be a finite number of seconds >= 0, got {max_dt:g}")
    if fx is None:
        given = [n for n, v in (("--fy", fy), ("--cx", cx), ("--cy", cy)) if v is not None]
        if given:
            raise ConfigError(f"{'/'.join(given)} given without --fx: give the intrinsics as "
                              f"--fx [--fy --cx --cy], or leave them all to intrinsics.json")


def register(app: typer.Typer) -> None:
    @app.command("import-views")
    def import_views_cmd(
        directory: Path = typer.Argument(..., help="TUM RGB-D directory (rgb.txt, depth.txt, "
                                         "groundtruth.txt, rgb/, depth/)."),
        out: Path = typer.Option(..., "--out", help="Views artifact to write (a directory, or "
                                 "a single file if it ends in .npz); must not exist yet."),
        fx: float = typer.Option(None, "--fx", help=f"Focal length x (px) {default('intrinsics.json')}."),
        fy: float = typer.Option(None, "--fy", help=f"Focal length y (px) {default('--fx')}."),
        cx: float = typer.Option(None, "--cx", help=f"Principal point x (px) {default('width / 2')}."),
        cy: float = typer.Option(None, "--cy", help=f"Principal point y (px) {default('height / 2')}."),
        camera_height: float = typer.Option(None, "--camera-height", help="Camera height above "
                                            f"the floor (m) {default('intrinsics.json, else the median camera z')}."),
        depth_scale: float = typer.Option(None, "--depth-scale", help="Depth PNG units per metre "
                                          f"{default('intrinsics.json, else 5000')}."),
        max_dt: float = typer.Option(0.02, "--max-dt", help="Timestamp association tolerance (s)."),
    ):
        """Read a TUM RGB-D layout (poses are camera-to-world) into a views artifact."""
        from navbench.errors import ConfigError
        from navbench.geometry import Intrinsics
        from navbench.worldmodel.tum import first_rgb_size, import_views
        from navbench.worldmodel.views import check_intrinsics, save_views

        _check_options(fx, fy, cx, cy, camera_height, depth_scale, max_dt)
        if out.exists() or out.is_symlink():
            raise ConfigError(f"--out {out}: already exists; choose a new path (import-views "
                              f"never overwrites)")
        intr, source = None, "given"
        if fx is not None:
            W, H = first_rgb_size(directory)
            source = "--fx/--fy/--cx/--cy and the first rgb image's size"
            intr = Intrinsics(W, H, fx, fy if fy is not None else fx,
                              cx if cx is not None else W / 2, cy if cy is not None else H / 2)
            for name, v, size in (("--cx", intr.cx, W), ("--cy", intr.cy, H)):
                if not 0 <= v <= size:
                    raise ConfigError(f"{name} {v:g} is outside the {W}x{H} image (0 .. {size})")
            check_intrinsics(intr, source)
        views = import_views(directory, intr, camera_height, depth_scale, max_dt,
                             intrinsics_source=source)
        save_views(views, out)
        i = views.intrinsics
        console.print(f"imported {len(views)} views ({i.width}x{i.height}, fx {i.fx:g}) from "
                      f"{directory} -> {out}; max camera tilt {views.meta['max_tilt_deg']:.2f} deg",
                      soft_wrap=True)
