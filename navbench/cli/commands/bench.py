"""``navbench bench``: time every per-step component and compare with the paper's figures."""

from __future__ import annotations

import math

import typer
from rich.markup import escape

from navbench.cli._common import console, err_console
from navbench.cli._help import DB_HELP, default
from navbench.pipeline.profiles import MAX_TASKS, MAX_WORKERS  # light


def _fmt(value, unit: str = "") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    v = float(value)
    digits = 3 if abs(v) < 1 else 2 if abs(v) < 10 else 1 if abs(v) < 1000 else 0
    return f"{v:.{digits}f}" + (f" {unit}" if unit else "")


def _print_table(result: dict) -> None:
    from rich.table import Table

    from navbench.bench import TARGETS, metric_keys

    targets = {t.key: t for t in TARGETS}
    table = Table(title=escape(f"navbench bench: {result['level']}, {result['map']}"), title_justify="left")
    for col, just in (("measurement", "left"), ("median", "right"), ("IQR", "right"),
                      ("min-max", "right"), ("n", "right"), ("paper (GPU)", "right"),
                      ("target", "left")):
        table.add_column(col, justify=just)
    group = None
    for key in metric_keys():
        unit = result["units"][key]
        if result["groups"][key] != group:
            if group is not None:
                table.add_section()
            group = result["groups"][key]
        st = result["stats"].get(key)
        iqr = f"{_fmt(st['q1'])}-{_fmt(st['q3'])}" if st else ""
        rng = f"{_fmt(st['min'])}-{_fmt(st['max'])}" if st else ""
        n = str(st["n"]) if st else ""
        paper = result["paper_vs"].get(key)
        tgt = ""
        if key in targets:
            t = targets[key]
            ok = t.check(result[key])
            verdict = "n/a" if ok is None else "[green]pass[/]" if ok else "[red]FAIL[/]"
            tgt = f"{t.op} {t.threshold:g}: {verdict}"
        value = _fmt(result[key], unit)
        if result[key] is None:
            value = "[dim]n/a[/]"
        table.add_row(result["labels"][key], value, iqr, rng, n,
                      _fmt(paper, unit) if paper is not None else "", tgt)
    console.print(table)
    console.print(f"host {result['host']}: {result['cpu']}; torch {result['torch_version']} "
                  f"({result['torch_threads']} threads), numba {result['numba_version']} "
                  f"({result['numba_threads']} threads), navbench {result['navbench_version']}; "
                  f"device {result['device']}", markup=False)
    cores = result.get("cpu_count") or 1
    load = max(result.get("load_avg_1m_start", 0.0), result.get("load_avg_1m_end", 0.0))
    busy = " -- the machine was BUSY (other processes competed for the CPUs)" if load > 0.75 * cores else ""
    console.print(f"load average (1 min) {result['load_avg_1m_start']:.2f} at the start, "
                  f"{result['load_avg_1m_end']:.2f} at the end, on {cores} CPUs{busy}")
    console.print(f"paper: {result['paper_hardware']}; NeRF render {_fmt(result['paper']['nerf_render_ms'], 'ms')} "
                  "(no NeRF in navbench). Medians over repeats after warm-up; "
                  f"{result['repeats']} repeats requested, fewer where a measurement hit its "
                  f"{result['config']['budget_s']:g} s budget; total {result['wall_s']:.0f} s.")
    shown = {"render_ms_paper", "fit_step_ms", "fit_10k_steps_s", "e2e_episodes_per_min", "e2e_episodes_per_min_paper"}
    for key, note in result["notes"].items():
        if key in shown or result[key] is None or note.startswith("quick"):
            console.print(f"  [dim]{escape(key)}: {escape(note)}[/]")


def bench(
    quick: bool = typer.Option(False, "--quick", help="Fewer repeats and a smaller end-to-end run (< 60 s)."),
    repeats: int = typer.Option(None, "--repeats", min=1, max=10_000,
                                help=f"Timed repeats per measurement {default('5 with --quick, else 20')}."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object instead of the table."),
    level: str = typer.Option("house-1", "--level", help="Level name (levels/NAME.json) or file."),
    seed: int = typer.Option(0, "--seed", min=0, max=2**63 - 1, help="Seed of every pose, pixel, walk and task drawn."),
    workers: int = typer.Option(0, "--workers", min=0, max=MAX_WORKERS,
                                help="Local worker processes of the end-to-end run (0: CPU count)."),
    e2e_tasks: int = typer.Option(None, "--e2e-tasks", min=0, max=MAX_TASKS,
                                  help=f"Tasks of the end-to-end run, 0 skips it {default('2 with --quick, else 6')}."),
    cache: str = typer.Option("results/cache", "--cache", envvar="NAVBENCH_CACHE", help="Stage cache to take a fitted map from."),
    map_file: str = typer.Option(None, "--map", help="A voxel map file (.npz) to time instead of the "
                                 "newest fitted map of the level in --cache: bench runs on the same "
                                 "file compare, whatever was fitted since."),
    store: bool = typer.Option(True, "--store/--no-store", help="Store the results in the results database."),
    cuda: bool = typer.Option(None, "--cuda/--no-cuda",
                              help="Also time the GPU path (differentiable render, fit step) on "
                                   f"cuda:0 {default('when torch sees a GPU')}."),
    db: str = typer.Option(None, "--db", envvar="NAVBENCH_DB",
                           help=DB_HELP),
):
    """Time the simulator, world model, planner, trackers, the full control step and whole
    episodes; print medians with their spread beside the paper's GPU figures and the speed
    targets, and store them in the results database (a report can then show the history).

    Numbers depend on the machine and on what else runs on it: the load average is printed.
    """
    import sys

    from contextlib import ExitStack

    from navbench.bench import BenchConfig, bench_rows, run_bench
    from navbench.levelio import resolve_level
    from navbench.pipeline.run import open_db, recorded_run

    resolve_level(level)  # a bad level name fails here, before a run is recorded
    if map_file is not None:  # and so does a bad map file
        from navbench.bench.timers import bench_map

        bench_map(None, None, cache, map_file)
    cfg = BenchConfig(level=level, quick=quick, repeats=repeats, seed=seed, workers=workers,
                      e2e_tasks=e2e_tasks, cache_root=cache, cuda=cuda, map_path=map_file)
    run_id = None
    with ExitStack() as stack:
        if store:
            rdb = stack.enter_context(open_db(db))
            run_id = stack.enter_context(recorded_run(rdb, "bench", "bench" + (" --quick" if quick else ""), cfg))
        if as_json:
            result = run_bench(config=cfg, progress=lambda s: err_console.print(f"[dim]bench: {escape(s)}[/]"))
        else:
            with console.status("benchmarking") as st:
                result = run_bench(config=cfg, progress=lambda s: st.update(f"benchmarking: {escape(s)}"))
        if run_id is not None:
            rdb.add_bench_rows(run_id, bench_rows(result))
            result["run_id"] = run_id
    if as_json:
        from navbench.cli._common import print_json

        print_json(result)
    else:
        _print_table(result)
        if run_id is not None:
            console.print(f"stored as run {run_id} in the results database")
    sys.stdout.flush()


def register(app: typer.Typer) -> None:
    app.command("bench")(bench)
