"""``navbench db``: where the results database is, what it holds, and its runs."""

from __future__ import annotations

import typer

from rich.markup import escape

from navbench.cli._common import FORMATS, check_format, console, print_records
from navbench.cli._help import DB_HELP

db_app = typer.Typer(help="Inspect the results database.", no_args_is_help=True)

_DB_OPTION = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                          help=DB_HELP)


@db_app.command("info")
def info(db: str = _DB_OPTION):
    """Show the database URL (password hidden) and the number of rows per table."""
    from rich.table import Table

    from navbench.results.db import ResultsDB

    with ResultsDB(db, create=False) as rdb:
        counts = rdb.table_counts()
        url = rdb.display_url
    table = Table(title=escape(url))
    table.add_column("table")
    table.add_column("rows", justify="right")
    for name, n in counts.items():
        table.add_row(escape(name), str(n))
    console.print(table)


@db_app.command("runs")
def runs(
    last: int = typer.Option(20, "--last", min=1, help="Show the N most recent runs."),
    fmt: str = typer.Option("table", "--format", help=f"{', '.join(FORMATS)}: a table, or every "
                            "value whole for a script or a page."),
    db: str = _DB_OPTION,
):
    """List runs: id, profile, command, status, start, duration, episodes stored, the earlier
    runs it resumed (interrupted runs of the same setup: `score --run latest` takes them too),
    git commit, host."""
    from rich.table import Table

    from navbench.results.db import ResultsDB

    check_format(fmt)
    with ResultsDB(db, create=False) as rdb:
        every = rdb.runs_frame()
        frame = every.tail(last)
        episodes = rdb.episodes_frame()
    per_run = episodes.groupby("run_id").size() if not episodes.empty else {}
    from navbench.results.db.resume import resume_chain

    columns = ["id", "profile", "command", "status", "started (UTC)", "seconds", "episodes",
               "resumes", "commit", "host"]
    rows = []
    for _, r in frame.iterrows():
        secs = None if r["finished"] is None or r["finished"] != r["finished"] else \
            round((r["finished"] - r["started"]).total_seconds())
        rows.append([int(r["id"]), str(r["profile"]), str(r["command"]), str(r["status"]),
                     r["started"].strftime("%Y-%m-%d %H:%M:%S"), secs, int(per_run.get(r["id"], 0)),
                     ", ".join(map(str, resume_chain(every, int(r["id"]))[:-1])),
                     (r["git_commit"] or "")[:10], str(r["host"])])
    if fmt != "table":
        print_records(columns, rows, fmt)
        return
    table = Table(title=f"{len(frame)} most recent run{'s' if len(frame) != 1 else ''}")
    for col in columns:
        table.add_column(col, justify="right" if col in ("id", "seconds", "episodes") else "left")
    for row in rows:  # profile, command line and host are user text: printed literally, never as markup
        table.add_row(*("" if v is None else escape(str(v)) for v in row))
    console.print(table)


def register(app: typer.Typer) -> None:
    app.add_typer(db_app, name="db")
