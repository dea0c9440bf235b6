"""The third H100 loan (2026-11-27 16:01-16:11 UTC): the paper profile under navbench-5 on 16
workers, houses 1-3 whole, and the six-level extrapolation.

    python docs/data/gpu/2026-11-27c/levels.py

Reads episodes.csv.gz (the 5400 episode rows the call stored, exported from its database) and
prints, per level, the episodes, their steps, the span between the level's first and last stored
episode, episodes a minute and steps a second; then the six-level extrapolation: the measured
time to the last stored episode of house-3, plus houses 4-6's steps (the 2-core `make paper`
under navbench-5 of 2026-11-27 10:58 UTC, run 1 of its database, scaled by the ratio of houses
1-3's steps there and here) at the steps-a-second of the levels with no background build beside
them, plus 30 s for score and report.
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd

HERE = Path(__file__).parent
#: runs.started of the call's run (its database), UTC
RUN_STARTED = pd.Timestamp("2026-11-27 16:01:45.909597")
#: total steps per level in the 2-core `make paper` under navbench-5 (paper5.db, run 1)
STEPS_2CORE = {"house-1": 207246, "house-2": 196167, "house-3": 135962,
               "house-4": 170675, "house-5": 194109, "house-6": 183594}
SCORE_REPORT_S = 30.0


def main() -> None:
    e = pd.read_csv(HERE / "episodes.csv.gz", parse_dates=["recorded"])
    g = e.groupby("level").agg(episodes=("steps", "size"), steps=("steps", "sum"),
                               first=("recorded", "min"), last=("recorded", "max"))
    g["span_s"] = (g["last"] - g["first"]).dt.total_seconds()
    g["episodes_per_min"] = 60 * g["episodes"] / g["span_s"]
    g["steps_per_s"] = g["steps"] / g["span_s"]
    print(g[["episodes", "steps", "span_s", "episodes_per_min", "steps_per_s"]].round(1).to_string())
    done_s = (e["recorded"].max() - RUN_STARTED).total_seconds()
    first_s = (e["recorded"].min() - RUN_STARTED).total_seconds()
    print(f"first episode stored {first_s:.0f} s after the run started; last {done_s:.0f} s "
          f"({len(e)} episodes, {60 * len(e) / (done_s - first_s):.0f} a minute between them)")
    ratio = g["steps"].sum() / sum(STEPS_2CORE[k] for k in g.index)
    rest = ratio * sum(v for k, v in STEPS_2CORE.items() if k not in g.index)
    for name, rate in (("house-1's (background beside it)", g.loc["house-1", "steps_per_s"]),
                       ("houses 2-3's", g.loc[["house-2", "house-3"], "steps"].sum()
                        / g.loc[["house-2", "house-3"], "span_s"].sum())):
        total = done_s + rest / rate + SCORE_REPORT_S
        print(f"six levels at {name} {rate:.0f} steps/s: {done_s:.0f} + {rest / rate:.0f} + "
              f"{SCORE_REPORT_S:.0f} s = {total / 60:.1f} min")


if __name__ == "__main__":
    main()
