"""``navbench show-level``: a PNG top view of a level."""

from __future__ import annotations

import os
from pathlib import Path

import typer

from navbench.cli._common import console
from navbench.cli._help import default


def register(app: typer.Typer) -> None:
    @app.command("show-level")
    def show_level(
        name: str = typer.Argument(..., help="Level name (levels/NAME.json) or path to a level file."),
        out: Path = typer.Option(None, "--out", help=f"PNG to write {default('results/levels/NAME.png')}."),
        doors: bool = typer.Option(False, "--doors", help="Mark the door centres."),
        dpi: int = typer.Option(120, "--dpi", min=20, max=600, help="Resolution of the PNG."),
    ):
        """Draw a level from above: walls, obstacles coloured by height, free space shaded."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.backend_bases import FigureCanvasBase

        from navbench.levelio import resolve_level
        from navbench.levelview import draw_level
        from navbench.outpath import check_output, writing

        # what savefig can write, by suffix (without one it would silently append .png)
        formats = tuple(sorted(f".{s}" for s in FigureCanvasBase.get_supported_filetypes()))
        if out is not None:  # checked before the level is read and drawn
            check_output(out, "--out", kind="file", suffixes=formats, example=f"{Path(name).stem}.png")
        level = resolve_level(name)
        if out is None:
            out = Path("results") / "levels" / f"{level.name}.png"
            check_output(out, "--out (default)", kind="file")
        fig, ax = plt.subplots(figsize=(6.4, 6.4 * level.depth / level.width + 0.4))
        # drawn into a temporary file beside OUT and renamed: never a half-written OUT
        tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
        try:
            draw_level(ax, level, doors=doors)
            fig.tight_layout()
            with writing(out, "--out", "the figure"):
                out.parent.mkdir(parents=True, exist_ok=True)
                fig.savefig(tmp, dpi=dpi, format=out.suffix[1:].lower())
                os.replace(tmp, out)
        finally:
            plt.close(fig)
            tmp.unlink(missing_ok=True)
        console.print(f"{level.name}: top view -> {out}", markup=False, highlight=False)
