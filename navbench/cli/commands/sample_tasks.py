"""``navbench sample-tasks LEVEL``: sample the benchmark's navigation tasks and write the task file."""

from __future__ import annotations

import typer

from navbench.cli._common import console
from navbench.cli._help import default


def sample_tasks_cmd(
    level: str = typer.Argument(..., help="Level name (levels/NAME.json) or path to a level file."),
    count: int = typer.Option(200, "--count", min=1, help="Number of tasks."),
    seed: int = typer.Option(0, "--seed", min=0, max=2**63 - 1, help="Sampling seed."),
    out: str = typer.Option(None, "--out", help=f"Output directory {default('tasks/')}."),
):
    """Sample start/target pairs (1.2 L clearance, > 3 L apart, reachable) with exact optimal lengths."""
    import numpy as np

    from navbench.plan.tasks import make_task_file

    if out is not None:  # a folder (the file is named LEVEL-COUNT-HASH.json): checked before sampling
        from pathlib import Path

        from navbench.errors import ConfigError
        from navbench.outpath import check_output

        if not Path(out).is_dir() and Path(out).suffix.lower() == ".json":
            raise ConfigError(f"--out {out}: names a file, but --out is the folder the task file "
                              f"goes in (named LEVEL-COUNT-HASH.json); give a folder, e.g. tasks")
        check_output(out, "--out", kind="dir", example="tasks")
    path, ts = make_task_file(level, count=count, seed=seed, out_dir=out)
    lengths = np.array([t.optimal_length for t in ts.tasks])
    # user text (paths, names) is printed without markup: a '[/x]' in a path is not a tag
    console.print(f"wrote {path}", markup=False, highlight=False)
    others = [p for p in path.parent.glob(f"{ts.level}-{ts.count}-*.json") if p != path]
    if others:
        console.print(f"note: other task files for {ts.level}: {', '.join(p.name for p in sorted(others))}",
                      markup=False, highlight=False)
    console.print(f"{ts.count} tasks in {ts.level} (seed {seed}, level sha256 {ts.level_sha256[:12]}): "
                  f"optimal length min {lengths.min():.2f} m, median {np.median(lengths):.2f} m, "
                  f"max {lengths.max():.2f} m", markup=False, highlight=False)


def register(app: typer.Typer) -> None:
    app.command("sample-tasks")(sample_tasks_cmd)
