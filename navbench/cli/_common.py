"""Small helpers shared by command modules (light imports only)."""

from __future__ import annotations

import json
import sys
from typing import Any

from rich.console import Console

console = Console(stderr=False, highlight=False)
err_console = Console(stderr=True, highlight=False)


def print_json(obj: Any) -> None:
    """Print one JSON object on stdout (for ``--json`` options)."""
    sys.stdout.write(json.dumps(obj, indent=2, sort_keys=True, default=float) + "\n")
    sys.stdout.flush()


def parse_list(text: str | None) -> list[str]:
    """``"a,b, c"`` -> ``["a", "b", "c"]``."""
    if not text:
        return []
    return [t.strip() for t in text.split(",") if t.strip()]
