"""Imports every estimator module so they register themselves. Add new modules here.

Also says which keyword options each estimator accepts (:func:`estimator_options_config`), so a
profile's ``[navigation.options.<estimator>]`` can be checked before any episode runs.

A module that fails to import is an error that surfaces as what it is (an ``ImportError`` with
its traceback), not as an "unknown estimator" later: every module listed here is part of
navbench and its dependencies are navbench's (heavy optional ones, torch, are imported inside
the functions that need them).
"""

import importlib

ESTIMATOR_MODULES = ("navbench.track.basic", "navbench.track.ours", "navbench.track.emission")

#: estimator name -> "module:ConfigClass", the frozen dataclass whose fields are the keyword
#: options its constructor accepts (besides the pipeline's vmap, intrinsics, camera_height,
#: renderer and seed). An estimator not listed accepts no options.
OPTIONS_CONFIGS = {
    "ours": "navbench.track.ours:TrackerConfig",
    "no-map": "navbench.track.ours:TrackerConfig",
    "emission": "navbench.track.emission:EmissionConfig",
}

for _mod in ESTIMATOR_MODULES:
    importlib.import_module(_mod)


def known_estimators() -> list[str]:
    """The registered estimator names, sorted."""
    from navbench.track.base import estimator_names

    return estimator_names()


def estimator_options_config(name: str):
    """The options dataclass of estimator ``name`` (its fields are the accepted options), or
    ``None`` when it accepts none. ``name`` must be registered (:func:`known_estimators`)."""
    spec = OPTIONS_CONFIGS.get(name)
    if spec is None:
        return None
    module, cls = spec.split(":")
    return getattr(importlib.import_module(module), cls)
