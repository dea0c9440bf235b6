"""``navbench cache ls`` and ``navbench cache gc``: inspect and prune the stage cache."""

from __future__ import annotations

import typer

from navbench.cli._common import console

cache_app = typer.Typer(help="Inspect and prune the stage cache (results/cache).", no_args_is_help=True)


def _cache_root(root: str):
    """``root`` as a Path; a file there is one error line, a missing folder is an empty cache."""
    from pathlib import Path

    from navbench.errors import ConfigError

    p = Path(root)
    if (p.exists() or p.is_symlink()) and not p.is_dir():
        raise ConfigError(f"--root {root}: is a file, not a cache folder (e.g. results/cache)")
    return p


def _human(n: int) -> str:
    for unit in ("B", "KB", "MB", "GB"):
        if n < 1024 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return str(n)


@cache_app.command("ls")
def ls(
    stage: str = typer.Option(None, "--stage", help="Only this stage."),
    root: str = typer.Option("results/cache", "--root", envvar="NAVBENCH_CACHE", help="Cache directory."),
):
    """List cached artifacts: stage, key, size, creation time and input keys."""
    from rich.markup import escape
    from rich.table import Table

    from navbench.pipeline.cache import ArtifactStore

    if stage is not None:  # a misspelt stage lists nothing: say so instead
        from navbench.errors import ConfigError
        from navbench.names import did_you_mean
        from navbench.pipeline.artifacts import FORMAT

        known = sorted({*FORMAT, "episode"})
        if stage not in known:
            raise ConfigError(f"--stage: unknown stage {stage!r}{did_you_mean(stage, known)}; "
                              f"choose one of {', '.join(known)}")
    if not _cache_root(root).is_dir():
        console.print(f"no cache at {escape(root)} yet: 0 artifacts")
        return
    store = ArtifactStore(root)
    infos = store.ls(stage)
    table = Table(title=f"{len(infos)} artifacts in {escape(root)}")
    for col in ("stage", "key", "size", "created", "inputs"):
        table.add_column(col, justify="right" if col == "size" else "left")
    episodes = [i for i in infos if i.stage == "episode"]
    for i in infos:
        if i.stage == "episode" and stage is None:
            continue
        inputs = ", ".join(f"{k}={v[:8]}" for k, v in sorted(i.inputs.items()))
        table.add_row(escape(i.stage), escape(i.key[:12]), _human(i.size), escape(str(i.created)),
                      escape(inputs))
    if episodes and stage is None:
        table.add_row("episode", f"({len(episodes)} items)", _human(sum(e.size for e in episodes)),
                      episodes[-1].created, "use --stage episode")
    console.print(table)


@cache_app.command("gc")
def gc(
    keep_newest: int = typer.Option(1, "--keep-newest", min=0,
                                    help="Also keep the N newest artifacts of every stage."),
    dry_run: bool = typer.Option(False, "--dry-run", help="List exactly what would be removed; remove nothing."),
    root: str = typer.Option("results/cache", "--root", envvar="NAVBENCH_CACHE",
                             help="Cache directory (it must be a navbench cache)."),
):
    """Remove artifacts no run refers to, and stale temporary directories.

    Kept: the artifacts of the latest run of every profile/command (results/cache/refs/), the
    newest N per stage, every artifact a running navbench process holds, everything they
    depend on, and episode trajectories whose level, map and task set are kept. Only a folder
    proven to be a navbench cache is collected, and only entries whose manifest navbench wrote
    (anything else is listed, never removed); see docs/concepts/bad-input.md.
    """
    from navbench.pipeline.cache import ArtifactStore

    if not _cache_root(root).is_dir():
        console.print(f"no cache at {root} yet: nothing to remove", markup=False)
        return
    rep = ArtifactStore(root).gc(keep_newest=keep_newest, dry_run=dry_run)
    verb = "would remove" if dry_run else "removed"
    for p in rep.removed:
        console.print(f"{verb} {p}", markup=False, highlight=False)
    for p, who in rep.held:
        console.print(f"kept {p}: in use by a running navbench process ({who})", markup=False, highlight=False)
    for p, why in rep.foreign:
        console.print(f"left {p}: not navbench's ({why})", markup=False, highlight=False)
    for p, why in rep.failed:
        console.print(f"could not remove {p}: {why}", markup=False, highlight=False)
    extra = "".join(f", {n} {what}" for n, what in ((len(rep.held), "in use"),
                                                      (len(rep.foreign), "not navbench's"),
                                                      (len(rep.failed), "not removable")) if n)
    console.print(f"{verb} {len(rep.removed)} entries{extra}", markup=False, highlight=False)


def register(app: typer.Typer) -> None:
    app.add_typer(cache_app, name="cache")
