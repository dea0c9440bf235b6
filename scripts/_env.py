"""Environment for the navbench subprocesses that scripts and tests start (standard library only:
golden_rows.py --code imports navbench from another checkout after this)."""

from __future__ import annotations

import os
from pathlib import Path


def pythonpath_first(*paths: str | Path) -> str:
    """A ``PYTHONPATH`` value with ``paths`` ahead of the one already set, which is kept: where the
    dependencies themselves come from a PYTHONPATH (wheels unpacked into a folder, as on the GPU
    machine, or a cluster's module system), replacing it would leave the child without them."""
    old = os.environ.get("PYTHONPATH")
    return os.pathsep.join([str(p) for p in paths] + ([old] if old else []))
