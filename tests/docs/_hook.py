"""The docs hook (docs/hooks/navbench_reference.py) imported by path: it is not a package module."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HOOK = ROOT / "docs" / "hooks" / "navbench_reference.py"


def load_hook():
    spec = importlib.util.spec_from_file_location("navbench_docs_hook", HOOK)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
