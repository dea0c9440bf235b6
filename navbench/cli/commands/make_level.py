"""``navbench make-level``: generate a level file ``levels/NAME.json`` (or all benchmark levels)."""

from __future__ import annotations

from pathlib import Path

import typer

from navbench.cli._common import console
from navbench.cli._help import default


def _write(level, force: bool) -> tuple[Path, str]:
    """Write ``levels/<name>.json`` under the working directory; refuse to replace a different
    file unless ``force``. Returns the path and what happened (written/unchanged/replaced)."""
    from navbench.errors import LevelError
    from navbench.levelio import dumps_level, level_path, save_level

    from navbench.outpath import check_output, writing

    path = level_path(level.name)
    check_output(path, None, kind="file")  # levels/ a file, NAME.json a folder, no permission
    text = dumps_level(level)
    if path.exists():
        try:
            old = path.read_text()
        except (OSError, UnicodeDecodeError):
            old = None
        if old == text:
            return path, "unchanged"
        if not force:
            raise LevelError(f"{path} exists and differs from the generated level; "
                             "pass --force to overwrite it")
        with writing(path, None, "the level"):
            save_level(level, path)
        return path, "replaced"
    from navbench.errors import ConfigError
    from navbench.outpath import exclusive_output

    try:  # a new file: published in one step that fails if another process wrote it meanwhile
        with exclusive_output(path, None, "the level") as tmp:
            tmp.parent.mkdir(parents=True, exist_ok=True)
            tmp.write_text(text, encoding="utf-8")
    except ConfigError:
        if not path.is_file():
            raise
        if path.read_text() != text:
            raise LevelError(f"{path} was written meanwhile (another process?) and differs from "
                             "the generated level; pass --force to overwrite it") from None
        return path, "unchanged"
    return path, "written"


def _summary(level, path: Path, what: str) -> str:
    """One line of rich markup; the name and the path are escaped (user text is not markup)."""
    from rich.markup import escape

    from navbench.levelgen import level_stats

    s = level_stats(level)
    rooms = f"{s['rooms']} rooms, " if s["rooms"] else ""
    return (f"[bold]{escape(level.name)}[/bold]: {rooms}{s['walls']} walls, {s['obstacles']} obstacles, "
            f"free area {s['free_area_m2']:.1f} m² at 1.2 L clearance, "
            f"{level.width:g} × {level.depth:g} m -> {escape(str(path))} ({what})")


def register(app: typer.Typer) -> None:
    @app.command("make-level")
    def make_level(
        name: str = typer.Argument(None, help="Level name; the file is levels/NAME.json."),
        seed: int = typer.Option(None, "--seed", min=0, max=2**63 - 1, help="Generator seed (required unless --benchmark)."),
        kind: str = typer.Option("house", "--kind", help="house, dense (more and smaller rooms, "
                                   "HouseExpo-like) or maze."),
        size: float = typer.Option(None, "--size", help="Footprint's longer side, metres "
                                   f"{default('11.4 for houses, 9.7 for the maze')}."),
        rooms: int = typer.Option(None, "--rooms", help="Number of rooms, corridor included "
                                  f"{default('drawn from the seed: 4-8 for house, 8-12 for dense')}."),
        obstacles: int = typer.Option(None, "--obstacles", help="Number of furniture obstacles."),
        from_houseexpo: Path = typer.Option(None, "--from-houseexpo", help="Import the outline "
                                            "of a HouseExpo JSON file instead of generating one."),
        benchmark: bool = typer.Option(False, "--benchmark", help="(Re)generate all the benchmark "
                                       "levels (BENCHMARK_LEVELS in navbench.levelgen)."),
        force: bool = typer.Option(False, "--force", help="Overwrite an existing, different file."),
        changed_from: str = typer.Option(None, "--changed-from", help="Derive NAME from this "
                                         "level (name or .json path) by moving, adding and "
                                         "removing furniture (RNR-Map's changed rooms)."),
        changes: int = typer.Option(None, "--changes", help="Furniture edits with --changed-from."),
    ):
        """Generate a level and write levels/NAME.json in the current directory."""
        from navbench.errors import ConfigError, LevelError
        from navbench import levelgen

        if benchmark:
            if name is not None or seed is not None or from_houseexpo is not None:
                raise ConfigError("--benchmark takes no NAME, --seed or --from-houseexpo")
            for lv in levelgen.benchmark_levels():
                path, what = _write(lv, force)
                console.print(_summary(lv, path, what))
            return
        if name is None:
            raise ConfigError("give a level NAME (or --benchmark)")
        if seed is None:
            raise ConfigError("--seed is required")
        if (changed_from is None) != (changes is None):
            raise ConfigError("--changed-from and --changes go together")
        if changed_from is not None:
            if from_houseexpo is not None or rooms is not None or obstacles is not None or size is not None:
                raise ConfigError("--changed-from takes no --from-houseexpo, --rooms, --obstacles or --size")
            from navbench.levelgen.changed import change_level
            from navbench.levelio import resolve_level

            level = change_level(resolve_level(changed_from), name, changes, seed)
            path, what = _write(level, force)
            console.print(_summary(level, path, what))
            return
        if from_houseexpo is not None:
            if kind != "house" or rooms is not None:  # (the outline is the document's)
                raise ConfigError("--from-houseexpo takes no --kind or --rooms")
            from navbench.safeio import load_json

            doc = load_json(from_houseexpo, LevelError, "HouseExpo file")
            try:
                level = levelgen.level_from_houseexpo(
                    doc, name, seed, size=levelgen.DEFAULT_SIZE if size is None else size,
                    obstacles=8 if obstacles is None else obstacles)
            except LevelError as e:  # name the file the user gave, not "HouseExpo document"
                raise LevelError(f"{from_houseexpo}: {str(e).removeprefix('HouseExpo document: ')}") from None
        else:
            level = levelgen.make_level(name, seed, kind=kind, size=size, rooms=rooms,
                                        obstacles=obstacles)
        path, what = _write(level, force)
        console.print(_summary(level, path, what))
