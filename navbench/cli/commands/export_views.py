"""``navbench export-views``: a navbench views artifact (a file or a cache key) -> the TUM
RGB-D layout."""

from __future__ import annotations

from pathlib import Path

import typer

from navbench.cli._common import console


def register(app: typer.Typer) -> None:
    @app.command("export-views")
    def export_views_cmd(
        views_spec: str = typer.Argument(..., metavar="VIEWS", help="Views artifact (directory or "
                                         ".npz) or the key (>= 6 hex digits) of a cached "
                                         "collect-views or import-views artifact."),
        directory: Path = typer.Argument(..., metavar="DIR", help="Output directory."),
    ):
        """Write views as TUM RGB-D: rgb/, depth/ (16-bit, m x 5000), rgb.txt, depth.txt,
        groundtruth.txt (camera-to-world poses) and intrinsics.json."""
        from navbench.errors import ConfigError
        from navbench.pipeline.stages.imported import is_tum_dir, resolve_views
        from navbench.worldmodel.tum import export_views

        if is_tum_dir(Path(views_spec)):
            raise ConfigError(f"VIEWS {views_spec}: a directory without views.json (a TUM "
                              f"directory is already exported; import-views reads it)")
        from navbench.outpath import check_output

        check_output(directory, "DIR", kind="dir", example="tum/seq1")  # before the views are read
        if directory.is_dir() and any(directory.iterdir()):
            raise ConfigError(f"DIR {directory}: directory is not empty; export into a new or "
                              f"empty directory")
        views, _ = resolve_views(views_spec, what="VIEWS")
        from navbench.outpath import exclusive_output

        with exclusive_output(directory, "DIR", "the export") as tmp:  # one of two racing exports wins
            export_views(views, tmp)
        # user text (paths, level names) is printed literally: a '[/x]' in a path is not a tag
        console.print(f"exported {len(views)} views of {views.level} -> {directory}",
                      markup=False, highlight=False)
