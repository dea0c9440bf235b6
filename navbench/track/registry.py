"""Imports every estimator module so they register themselves. Add new modules here."""

import contextlib
import importlib

for _mod in ("navbench.track.basic", "navbench.track.ours", "navbench.track.emission"):
    with contextlib.suppress(ModuleNotFoundError):
        importlib.import_module(_mod)
