"""report: the HTML report of a set of cells, cached by the score and the stored episodes."""

from __future__ import annotations

from pathlib import Path

from navbench.errors import ArtifactError
from navbench.pipeline.artifacts import REPORT_INDEX
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.grid import Cell
from navbench.pipeline.stages.score import episodes_state_key


def report_stage(ctx: StageContext, cells: list[Cell], score: Ref, preset: str = "paper") -> Ref:
    """The HTML report (:func:`navbench.report.build.build_report`) of these cells' episodes
    (as the score stage), with trajectories and maps read from this store, cached by the score
    artifact and the cells' stored episodes (so a rerun that adds nothing does not redraw it;
    its run list is as of the last redraw)."""
    state = episodes_state_key(ctx, cells)

    def compute(d: Path) -> None:
        from navbench.pipeline.loaders import store_loaders
        from navbench.report.build import build_report

        load_trajectory, load_map = store_loaders(ctx.store.root)
        index = Path(build_report(ctx.db, d, load_trajectory, load_map, levels_dir=ctx.levels_dir,
                                  cell_keys=[c.key for c in cells], preset=preset))
        if index.name != REPORT_INDEX or index.parent.resolve() != d.resolve():
            raise ArtifactError(f"build_report wrote {index}, expected {d / REPORT_INDEX}")

    config = {"format": 1} if preset == "paper" else {"format": 1, "preset": preset}  # issue 15
    path, key, cached = ctx.run("report", config, {"score": score.key, "episodes": state}, compute)
    return Ref("report", key, path / REPORT_INDEX, cached)
