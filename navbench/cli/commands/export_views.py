"""``navbench export-views``: a navbench views artifact -> the TUM RGB-D layout."""

from __future__ import annotations

from pathlib import Path

import typer

from navbench.cli._common import console


def register(app: typer.Typer) -> None:
    @app.command("export-views")
    def export_views_cmd(
        views_path: Path = typer.Argument(..., metavar="FILE", help="Views artifact (directory or .npz)."),
        directory: Path = typer.Argument(..., metavar="DIR", help="Output directory."),
    ):
        """Write views as TUM RGB-D: rgb/, depth/ (16-bit, m x 5000), rgb.txt, depth.txt,
        groundtruth.txt (camera-to-world poses) and intrinsics.json."""
        from navbench.worldmodel.tum import export_views
        from navbench.worldmodel.views import load_views

        views = load_views(views_path)
        export_views(views, directory)
        console.print(f"exported {len(views)} views of {views.level} -> {directory}", soft_wrap=True)
