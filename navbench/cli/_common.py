"""Small helpers shared by command modules (light imports only)."""

from __future__ import annotations

import json
import sys
from typing import Any

from rich.console import Console, ConsoleDimensions

#: The width tables lay out at when the output is not a terminal (a pipe, a file): wide enough
#: that no name or command is cut (``ours…`` for both ``ours`` and ``ours-every-k``); a table
#: takes only the width its cells need.
PIPED_WIDTH = 1000


class _Console(Console):
    """A rich console that lays tables out at :data:`PIPED_WIDTH` when its stream is not a
    terminal (rich's own fallback is 80 columns, or the width of a terminal on stdin) unless
    ``$COLUMNS`` says otherwise; on a terminal, the terminal's width. ``$COLUMNS`` is read at
    each print, not once when the module is imported (rich's)."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self._width = kwargs.get("width")

    def _size(self) -> ConsoleDimensions:
        import os

        dims = Console.size.fget(self)
        if self._width is None:
            columns = os.environ.get("COLUMNS", "")
            if columns.isdigit() and int(columns) > 0:
                return ConsoleDimensions(int(columns), dims.height)
            if not self.is_terminal:
                return ConsoleDimensions(PIPED_WIDTH, dims.height)
        return dims

    size = property(_size, Console.size.fset)

    def print(self, *objects: Any, **kwargs: Any) -> None:
        """As rich's, but a table's cells are never cut short with an ellipsis (``ours…`` for
        both ``ours`` and ``ours-every-k``): on a narrow terminal a long cell folds onto more lines."""
        from rich.table import Table

        for obj in objects:
            if isinstance(obj, Table):
                for col in obj.columns:
                    if col.overflow == "ellipsis":
                        col.overflow = "fold"
        super().print(*objects, **kwargs)


# soft_wrap: a printed line is never broken at the console's width, so a long path stays one
# line that a script can parse and a user can paste; tables and other renderables still lay out
# at the width.
console = _Console(stderr=False, highlight=False, soft_wrap=True)
err_console = _Console(stderr=True, highlight=False, soft_wrap=True)


def print_json(obj: Any) -> None:
    """Print one JSON object on stdout (for ``--json`` options)."""
    sys.stdout.write(json.dumps(obj, indent=2, sort_keys=True, default=float) + "\n")
    sys.stdout.flush()


def parse_list(text: str | None) -> list[str]:
    """``"a,b, c"`` -> ``["a", "b", "c"]``."""
    if not text:
        return []
    return [t.strip() for t in text.split(",") if t.strip()]


def parse_estimator_options(items: list[str]) -> dict[str, dict]:
    """``["ours.optimizer=adam", "emission.steps=100"]`` -> ``{"ours": {...}, "emission": {...}}``.

    Values are read as JSON when possible (numbers, lists, true/false), else kept as strings;
    NaN, infinities and values nested too deep are refused in one line
    (:func:`navbench.safeio.parse_option_value`).
    """
    from navbench.errors import ConfigError
    from navbench.safeio import parse_option_value

    out: dict[str, dict] = {}
    for item in items:
        key, sep, value = item.partition("=")
        name, dot, opt = key.partition(".")
        if not sep or not dot or not name or not opt:
            raise ConfigError(f"--option expects ESTIMATOR.KEY=VALUE, got {item!r}")
        val = parse_option_value(value, f"--option {key}")
        out.setdefault(name.strip(), {})[opt.strip()] = val
    return out


#: Output formats of table-printing commands (``--format``).
FORMATS = ("table", "csv", "json", "markdown")


def check_format(fmt: str, option: str = "--format") -> str:
    from navbench.errors import ConfigError
    from navbench.names import did_you_mean

    if fmt not in FORMATS:
        raise ConfigError(f"{option} {fmt}: unknown format{did_you_mean(fmt, FORMATS)}; choose one of {', '.join(FORMATS)}")
    return fmt


def print_records(columns: list[str], rows: list[list[Any]], fmt: str) -> None:
    """Rows of plain values as CSV, a JSON list of objects or a Markdown table on stdout
    (``fmt`` one of :data:`FORMATS` other than ``table``), every value whole."""
    if fmt == "json":
        print_json([dict(zip(columns, r)) for r in rows])
    elif fmt == "csv":
        import csv

        w = csv.writer(sys.stdout, lineterminator="\n")
        w.writerow(columns)
        w.writerows(rows)
    elif fmt == "markdown":
        def cell(v: Any) -> str:
            return "" if v is None else str(v).replace("|", "\\|").replace("\n", " ")

        sys.stdout.write("| " + " | ".join(columns) + " |\n")
        sys.stdout.write("|" + "|".join("---" for _ in columns) + "|\n")
        for r in rows:
            sys.stdout.write("| " + " | ".join(cell(v) for v in r) + " |\n")
    else:
        raise ValueError(fmt)
    sys.stdout.flush()
