"""``navbench export-trajectories``: stored episodes' and track-eval trajectories as TUM files."""

from __future__ import annotations

from pathlib import Path

import typer

from navbench.cli._common import console, parse_list, print_json
from navbench.cli._help import DB_HELP, default


def register(app: typer.Typer) -> None:
    @app.command("export-trajectories")
    def export_trajectories_cmd(
        out: Path = typer.Argument(..., metavar="DIR", help="Output directory (new or empty)."),
        run: str = typer.Option(None, "--run", metavar="ID[,ID..]|latest",
                                 help="Only these runs' rows ('latest': the newest run, with the "
                                 "interrupted runs it resumed)."),
        level: str = typer.Option(None, "--level", help="Comma-separated level names."),
        estimator: str = typer.Option(None, "--estimator", help="Comma-separated estimator names."),
        noise: str = typer.Option(None, "--noise", help="Comma-separated noise levels (track-eval "
                                  "studies: tracking)."),
        task: str = typer.Option(None, "--task", help="Comma-separated task ids (track-eval: "
                                 "trajectory indices)."),
        source: str = typer.Option("all", "--source", help="all, episodes (run-navigation) or "
                                   "track-eval (tracking studies)."),
        dt: float = typer.Option(0.1, "--dt", help="Seconds between poses (timestamp = step x dt)."),
        json_out: bool = typer.Option(False, "--json", help="Print one JSON object."),
        db: str = typer.Option(None, "--db", help=DB_HELP),
        cache: Path = typer.Option(None, "--cache", envvar="NAVBENCH_CACHE", help="Stage cache holding "
                                   f"the trajectories {default('results/cache, or $NAVBENCH_CACHE')}."),
    ):
        """Write true and estimated trajectories as TUM pose files, one pair per trajectory.

        Each stored episode (run-navigation) or track-eval trajectory the options select
        becomes two files with identical timestamps: X.gt.txt and X.est.txt in a folder
        episodes/LEVEL or track-eval/LEVEL of DIR, where X names the estimator, noise, task
        (or trajectory), seed and key. DIR/index.csv lists every pair. Check one with evo:
        evo_ape tum X.gt.txt X.est.txt
        """
        import dataclasses

        from navbench.errors import ConfigError
        from navbench.pipeline.cache import ArtifactStore
        from navbench.pipeline.run import open_db
        from navbench.pipeline.tracking import export_trajectories

        from navbench.outpath import check_output

        check_output(out, "DIR", kind="dir", example="trajectories")  # before the database is read
        if cache is not None and not cache.is_dir():
            raise ConfigError(f"--cache {cache}: no such folder (a stage cache, e.g. results/cache)")
        try:
            tasks = [int(t) for t in parse_list(task)] or None
        except ValueError:
            raise ConfigError(f"--task: expected comma-separated whole numbers, got {task!r}") from None
        with open_db(db) as rdb:
            from navbench.results.db.resume import resolve_run_ids

            run_id = resolve_run_ids(rdb, run, latest="any")
            if out.is_dir() and any(out.iterdir()):
                raise ConfigError(f"{out}: exists and is not an empty directory; export into a new one")
            from navbench.outpath import exclusive_output

            with exclusive_output(out, "DIR", "the export") as tmp:  # one of two racing exports wins
                pairs = export_trajectories(tmp, rdb, run=run_id, level=parse_list(level) or None,
                                            estimator=parse_list(estimator) or None,
                                            noise=parse_list(noise) or None, task=tasks, source=source, dt=dt,
                                            store=ArtifactStore(cache))
            pairs = [dataclasses.replace(p, gt=out / p.gt.relative_to(tmp), est=out / p.est.relative_to(tmp))
                     for p in pairs]
        if json_out:
            print_json({"out": str(out), "pairs": len(pairs), "index": str(out / "index.csv"),
                        "files": [{"gt": str(p.gt), "est": str(p.est), "source": p.source,
                                   "level": p.level, "estimator": p.estimator, "noise": p.noise,
                                   "task": p.task, "seed": p.seed, "loc_rmse_m": p.loc_rmse_m}
                                  for p in pairs]})
            return
        n_ep = sum(p.source == "episode" for p in pairs)
        console.print(f"exported {len(pairs)} trajectory pairs ({n_ep} episodes, "
                      f"{len(pairs) - n_ep} track-eval) -> {out} (index: {out / 'index.csv'})",
                      markup=False)
