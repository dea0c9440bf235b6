"""``navbench import-views``: a TUM RGB-D directory -> a navbench views artifact."""

from __future__ import annotations

from pathlib import Path

import typer

from navbench.cli._common import console


def register(app: typer.Typer) -> None:
    @app.command("import-views")
    def import_views_cmd(
        directory: Path = typer.Argument(..., help="TUM RGB-D directory (rgb.txt, depth.txt, "
                                         "groundtruth.txt, rgb/, depth/)."),
        out: Path = typer.Option(..., "--out", help="Views artifact to write (a directory, or "
                                 "a single file if it ends in .npz)."),
        fx: float = typer.Option(None, "--fx", help="Focal length x (px) [default: intrinsics.json]."),
        fy: float = typer.Option(None, "--fy", help="Focal length y (px) [default: --fx]."),
        cx: float = typer.Option(None, "--cx", help="Principal point x (px) [default: width / 2]."),
        cy: float = typer.Option(None, "--cy", help="Principal point y (px) [default: height / 2]."),
        camera_height: float = typer.Option(None, "--camera-height", help="Camera height above "
                                            "the floor (m) [default: intrinsics.json, else the "
                                            "median camera z]."),
        depth_scale: float = typer.Option(None, "--depth-scale", help="Depth PNG units per metre "
                                          "[default: 5000]."),
        max_dt: float = typer.Option(0.02, "--max-dt", help="Timestamp association tolerance (s)."),
    ):
        """Read a TUM RGB-D layout (poses are camera-to-world) into a views artifact."""
        from navbench.errors import ArtifactError
        from navbench.geometry import Intrinsics
        from navbench.worldmodel.views import import_views, save_views

        intr = None
        if fx is not None:
            from PIL import Image

            rgb_list = directory / "rgb"
            first = next(iter(sorted(rgb_list.glob("*.png"))), None) if rgb_list.is_dir() else None
            if first is None:
                raise ArtifactError(f"{directory}: no rgb/*.png to read the image size from")
            W, H = Image.open(first).size
            intr = Intrinsics(W, H, fx, fy if fy is not None else fx,
                              cx if cx is not None else W / 2, cy if cy is not None else H / 2)
        views = import_views(directory, intr, camera_height, depth_scale, max_dt)
        save_views(views, out)
        i = views.intrinsics
        console.print(f"imported {len(views)} views ({i.width}x{i.height}, fx {i.fx:g}) from "
                      f"{directory} -> {out}; max camera tilt {views.meta['max_tilt_deg']:.2f} deg",
                      soft_wrap=True)
