"""``navbench level-difficulty``: how hard each level's tasks are (true geometry; issue 16)."""

from __future__ import annotations

import typer

from navbench.cli._common import console, print_json
from navbench.cli._help import default


def register(app: typer.Typer) -> None:
    @app.command("level-difficulty")
    def level_difficulty_cmd(
        levels: list[str] = typer.Argument(None, help="Level names (levels/NAME.json) or level files "
                                           f"{default('every level with a task file in tasks/')}."),
        count: int = typer.Option(None, "--count", min=1, help="Use the first COUNT tasks of each task "
                                  f"file {default('all')}."),
        as_json: bool = typer.Option(False, "--json", help="Print the rows as JSON."),
    ):
        """Per level: mean geodesic / Euclidean task distance, the narrowest passage on the shortest
        paths (median, min), mean path length and fewest steps, free-space clearance and the share
        of free space the planner may use (>= 1.2 L from solids)."""
        from pathlib import Path

        from navbench.errors import TaskError
        from navbench.levelio import resolve_level
        from navbench.plan.difficulty import level_difficulty
        from navbench.plan.tasks import check_tasks_on_level, find_task_file, read_task_file

        if not levels:
            levels = sorted({p.name.rsplit("-", 2)[0] for p in Path("tasks").glob("*-*-*.json")})
            if not levels:
                raise TaskError("no task files in tasks/; give level names or run `navbench sample-tasks`")
        rows = []
        for name in levels:
            level = resolve_level(name)
            path = find_task_file(level.name)
            ts = read_task_file(path)
            if ts.level != level.name:  # a file of another level under this one's name
                raise TaskError(f"{path}: level: says {ts.level!r} but the file name says {level.name!r}")
            tasks = list(ts.tasks)[:count]
            # the checks run-navigation applies (issue 34, P-008): a start on its target, a made-up
            # optimal_length or a wall-bound point is refused, not measured (0 / 0, made-up figures)
            check_tasks_on_level(level, tasks, str(path))
            rows.append(level_difficulty(level, tasks).summary())
        if as_json:
            print_json(rows)
            return
        console.print(f"{'level':<12} {'tasks':>5} {'geo/eucl':>8} {'door med':>8} {'door min':>8} "
                      f"{'length':>7} {'steps':>6} {'clear':>6} {'plan%':>6}", markup=False)
        for r in rows:
            console.print(f"{r['level']:<12} {r['tasks']:>5} {r['geodesic_ratio']:>8.3f} "
                          f"{r['narrowest_passage_median']:>8.2f} {r['narrowest_passage_min']:>8.2f} "
                          f"{r['length']:>7.2f} {r['min_steps']:>6.1f} {r['free_clearance']:>6.2f} "
                          f"{100 * r['planner_free']:>6.1f}", markup=False)
        console.print("geo/eucl: shortest path / straight line; door: narrowest width across the "
                      "shortest path, its first and last 0.5 m left out (m); length (m) and steps "
                      "(ceil(length / 0.8 L)): the shortest path; clear: mean clearance of the "
                      "reachable free space (m); plan%: its share >= 1.2 L from solids",
                      markup=False)
