"""``navbench import-views``: a TUM RGB-D directory -> a navbench views artifact (a file, the
cache, or both)."""

from __future__ import annotations

from pathlib import Path

import typer

from navbench.cli import _tum
from navbench.cli._common import console, print_json


def register(app: typer.Typer) -> None:
    @app.command("import-views")
    def import_views_cmd(
        directory: Path = typer.Argument(..., help="TUM RGB-D directory (rgb.txt, depth.txt, "
                                         "groundtruth.txt, rgb/, depth/)."),
        out: Path = typer.Option(None, "--out", help="Views artifact to write (a directory, or "
                                 "a single file if it ends in .npz; no other suffix); must not exist yet."),
        store: bool = typer.Option(False, "--store", help="Store the views in the cache (keyed by "
                                   "their content) and print the key, for fit-map --views KEY."),
        fx: float = _tum.FX, fy: float = _tum.FY, cx: float = _tum.CX, cy: float = _tum.CY,
        camera_height: float = _tum.CAMERA_HEIGHT, depth_scale: float = _tum.DEPTH_SCALE,
        max_dt: float = _tum.MAX_DT, max_tilt: float = _tum.MAX_TILT,
        max_height_dev: float = _tum.MAX_HEIGHT,
        json_out: bool = typer.Option(False, "--json", help="Print one JSON object (count, key, out)."),
    ):
        """Read a TUM RGB-D layout (poses are camera-to-world) into a views artifact (--out),
        the cache (--store), or both. Tilted or off-height (6-DoF) poses are refused."""
        from navbench.errors import ConfigError
        from navbench.worldmodel.views import save_views, views_content_hash

        opts = _tum.import_options(fx, fy, cx, cy, camera_height, depth_scale, max_dt, max_tilt,
                                   max_height_dev)
        if out is None and not store:
            raise ConfigError("import-views: give --out PATH, --store, or both")
        if out is not None and (out.exists() or out.is_symlink()):
            raise ConfigError(f"--out {out}: already exists; choose a new path (import-views "
                              f"never overwrites)")
        if out is not None and out.suffix and out.suffix != ".npz":
            raise ConfigError(f"--out {out}: a views artifact is a folder (a name without a "
                              f"suffix, e.g. views/seq1) or one .npz file (e.g. views.npz), "
                              f"not {out.suffix}")
        if out is not None:  # a parent that is a file, or nowhere to write: before reading
            from navbench.outpath import check_output

            check_output(out, "--out", kind="file" if out.suffix == ".npz" else "dir",
                         example="views.npz")
        views = opts.read(directory)
        content = views_content_hash(views)
        if out is not None:  # published in one step that fails if --out appeared meanwhile
            from navbench.outpath import exclusive_output

            with exclusive_output(out, "--out", "the views") as tmp:
                save_views(views, tmp)
        ref = None
        if store:
            from navbench.pipeline.run import stage_context
            from navbench.pipeline.stages.imported import store_views_stage

            ref = store_views_stage(stage_context(), views, content)
        i = views.intrinsics
        if json_out:
            print_json({"count": len(views), "content_key": content, "out": str(out) if out else None,
                        "key": ref.key if ref else None, "width": i.width, "height": i.height,
                        "max_tilt_deg": views.meta["max_tilt_deg"]})
            return
        where = " and ".join(([str(out)] if out else []) + ([f"the cache, key {ref.key[:12]}"] if ref else []))
        console.print(f"imported {len(views)} views ({i.width}x{i.height}, fx {i.fx:g}) from "
                      f"{directory} -> {where}; max camera tilt {views.meta['max_tilt_deg']:.2f} deg",
                      markup=False, highlight=False)  # paths are not markup
