"""Small helpers shared by command modules (light imports only)."""

from __future__ import annotations

import json
import sys
from typing import Any

from rich.console import Console

# soft_wrap: a printed line is never broken at the console's width (80 columns when output is
# piped), so a long path stays one line that a script can parse and a user can paste; tables
# and other renderables still lay out at the width.
console = Console(stderr=False, highlight=False, soft_wrap=True)
err_console = Console(stderr=True, highlight=False, soft_wrap=True)


def print_json(obj: Any) -> None:
    """Print one JSON object on stdout (for ``--json`` options)."""
    sys.stdout.write(json.dumps(obj, indent=2, sort_keys=True, default=float) + "\n")
    sys.stdout.flush()


def parse_list(text: str | None) -> list[str]:
    """``"a,b, c"`` -> ``["a", "b", "c"]``."""
    if not text:
        return []
    return [t.strip() for t in text.split(",") if t.strip()]
