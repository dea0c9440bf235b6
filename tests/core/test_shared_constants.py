"""Shared constants have one definition (issue 12): the per-step timing components of an
episode and the camera preset names. Every user imports the same object, so a component or a
camera added in one place cannot be missing from another (the database columns, the report's
runtime table and figure, the profile check, the benchmark table)."""

from __future__ import annotations

import ast
from pathlib import Path

from navbench import geometry
from navbench.bench import table as bench_table
from navbench.nav import episode, timing
from navbench.pipeline import profiles
from navbench.report import build as report
from navbench.report import plots
from navbench.results.db import EpisodeRow
from navbench.results.db import rows as db_rows
from navbench.results.db import schema as db_schema

PKG = Path(__file__).resolve().parents[2] / "navbench"


def _literal_tuples(values: tuple[str, ...]) -> list[str]:
    """``file:line`` of every tuple or list literal in navbench made of exactly these strings
    (in any order)."""
    hits = []
    for path in sorted(PKG.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.Tuple, ast.List)) and node.elts and all(
                    isinstance(e, ast.Constant) and isinstance(e.value, str) for e in node.elts):
                if sorted(e.value for e in node.elts) == sorted(values):
                    hits.append(f"{path.relative_to(PKG.parent)}:{node.lineno}")
    return hits


def test_timing_keys_are_one_object_everywhere():
    assert episode.TIMING_KEYS is timing.TIMING_KEYS
    assert db_rows.TIMING_KEYS is timing.TIMING_KEYS
    assert plots.TIMING_KEYS is timing.TIMING_KEYS
    assert db_schema.TIMING_COLUMNS is timing.TIMING_COLUMNS
    assert report.TIMING_COLUMNS is timing.TIMING_COLUMNS
    assert timing.TIMING_COLUMNS == tuple(f"{k}_ms" for k in timing.TIMING_KEYS)


def test_timing_keys_spelled_only_in_their_module():
    hits = _literal_tuples(timing.TIMING_KEYS)
    assert [h.split(":")[0] for h in hits] == ["navbench/nav/timing.py"], hits


def test_episode_table_and_figure_cover_exactly_the_timing_keys():
    """The ``episodes`` model spells its columns out (it is the schema); they must be the
    timing columns, in order, and the runtime figure must have a colour for each component."""
    per_component = [c for c in EpisodeRow.__table__.c.keys() if c.endswith("_ms") and c != "step_ms"]
    assert per_component == list(timing.TIMING_COLUMNS)
    assert set(plots.COMPONENT_COLOURS) == set(timing.TIMING_KEYS)


def test_camera_names_are_the_presets():
    assert geometry.CAMERA_NAMES == tuple(geometry.CAMERAS) == ("half", "paper")
    assert profiles.CAMERA_NAMES is geometry.CAMERA_NAMES
    assert bench_table.CAMERA_NAMES is geometry.CAMERA_NAMES
