"""``navbench show-level``: a PNG top view of a level."""

from __future__ import annotations

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

        from navbench.levelio import resolve_level
        from navbench.levelview import draw_level

        level = resolve_level(name)
        out = out if out is not None else Path("results") / "levels" / f"{level.name}.png"
        out.parent.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(6.4, 6.4 * level.depth / level.width + 0.4))
        try:
            draw_level(ax, level, doors=doors)
            fig.tight_layout()
            fig.savefig(out, dpi=dpi)
        finally:
            plt.close(fig)
        console.print(f"{level.name}: top view -> {out}", markup=False, highlight=False)
