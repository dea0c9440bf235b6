"""Load a script of the repository as a module, for the tests of those scripts: developer tools
under ``scripts/`` by name, the scripts behind recorded figures by their path under ``docs/data/``."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def script_path(name: str) -> Path:
    """``scripts/<name>.py`` for a bare name, else ``name`` relative to the repository root."""
    return ROOT / name if "/" in name else ROOT / "scripts" / f"{name}.py"


def load_script(name: str):
    """The script :func:`script_path` names, imported under the module name of its file's stem."""
    path = script_path(name)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
