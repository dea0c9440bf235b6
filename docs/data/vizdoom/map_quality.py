"""Issue 37 §4: held-out map quality per house on both backends, from the ``maps`` table the
fit-map stage writes (200 held-out views of each backend's own camera; the slice is the planner's
occupancy slice against the level's true one).

``python docs/data/vizdoom/map_quality.py PYMUNK_DB VIZDOOM_DB`` (sqlite paths) prints a Markdown
table: depth MAE (m), RGB L1, slice precision and recall per level, pymunk / ViZDoom."""

from __future__ import annotations

import sqlite3
import sys

COLUMNS = ("depth_mae_m", "rgb_l1", "slice_precision", "slice_recall")


def maps(path: str) -> dict:
    with sqlite3.connect(path) as con:
        rows = con.execute(f"SELECT level, {', '.join(COLUMNS)} FROM maps ORDER BY level, id").fetchall()
    return {r[0]: r[1:] for r in rows}  # the last fit of a level wins (one per level here)


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        return 2
    pym, viz = maps(argv[0]), maps(argv[1])
    print("| level | depth MAE, m | RGB L1 | slice precision | slice recall |")
    print("|---|---|---|---|---|")
    digits = (4, 4, 3, 3)
    for level in sorted(set(pym) & set(viz)):
        cells = [f"{p:.{d}f} / {v:.{d}f}" for p, v, d in zip(pym[level], viz[level], digits)]
        print(f"| {level} | {' | '.join(cells)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
