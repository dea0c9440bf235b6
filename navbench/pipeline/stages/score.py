"""score: the score table of a set of cells, cached by the set of stored episodes."""

from __future__ import annotations

from pathlib import Path

from navbench.config import config_hash
from navbench.pipeline.artifacts import PAIRED_FILE, SCORE_FILE

DIFFICULTY_FILE = "by_difficulty.csv"  # beside score.csv: issue 15's table by NRNS difficulty
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.grid import Cell


def episodes_state_key(ctx: StageContext, cells: list[Cell]) -> str:
    """A key for everything stored about ``cells``: the sorted (cell, task, seed) triples."""
    done = sorted(ctx.db.done_episode_keys([c.key for c in cells]))
    return config_hash({"cells": sorted(c.key for c in cells), "episodes": [list(t) for t in done]})


def score_stage(ctx: StageContext, cells: list[Cell], preset: str = "paper") -> Ref:
    """The score table of exactly these cells (:func:`navbench.results.score.select_episodes`
    restricted to the cells' keys, then :func:`~navbench.results.score.summarise`), cached by
    the set of stored episodes; the artifact is ``score.csv`` and, beside it,
    ``paired_differences.csv`` (:func:`~navbench.results.score.paired_differences`: the paper's
    claim, ``ours`` minus each ablation on the same tasks and seeds), and
    ``by_difficulty.csv`` (:func:`~navbench.results.score.difficulty_table`), all under
    the scoring ``preset`` (:mod:`navbench.nav.presets`; part of the key unless ``paper``)."""
    state = episodes_state_key(ctx, cells)
    levels = sorted({c.level for c in cells})

    def compute(d: Path) -> None:
        from navbench.results.score import paired_differences, select_episodes, summarise
        from navbench.results.score import difficulty_table
        from navbench.results.presets import apply_preset

        frame = apply_preset(select_episodes(ctx.db, level=levels, cell_keys=cell_keys), preset)
        summarise(frame).to_csv(d / SCORE_FILE, index=False)
        paired_differences(frame).to_csv(d / PAIRED_FILE, index=False)
        difficulty_table(frame).to_csv(d / DIFFICULTY_FILE, index=False)

    cell_keys = sorted(c.key for c in cells)
    config = {"levels": levels} if preset == "paper" else {"levels": levels, "preset": preset}
    path, key, cached = ctx.run("score", config, {"episodes": state}, compute)
    return Ref("score", key, path / SCORE_FILE, cached)
