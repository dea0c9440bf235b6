"""Plugins: code from other distributions that navbench finds through entry points.

A distribution adds an estimator (or, later, a world model) by declaring an entry point in its
``pyproject.toml``::

    [project.entry-points."navbench.estimators"]
    ours-every-k = "navbench_example:OursEveryK"

The entry point's *name* is the name users type (``--estimators ours-every-k``); its *value*
is ``module:attribute``. Entry points are read from the installed distributions' metadata on
``sys.path`` (:func:`importlib.metadata.entry_points`), so a worker process that inherits the
parent's ``sys.path`` (``PYTHONPATH``, the same environment) finds the same plugins.

This module only finds and imports them; what a group's objects must look like is the business
of its registry (:mod:`navbench.track.registry` for estimators). A plugin that fails to import
is a :class:`~navbench.errors.PluginError` naming the plugin and its distribution (one line in
the CLI), never a traceback and never an "unknown name".
"""

from __future__ import annotations

import importlib.metadata
from dataclasses import dataclass
from typing import Any

from navbench.errors import PluginError
from navbench.names import SAFE_NAME_RULE, is_safe_name

#: Entry-point group of pose estimators (value: the estimator class).
ESTIMATORS_GROUP = "navbench.estimators"
#: Entry-point group of world models (value: the world-model class; see navbench.worldmodel).
WORLD_MODELS_GROUP = "navbench.world_models"


@dataclass(frozen=True)
class Plugin:
    """One entry point of a group, found but not imported yet."""

    group: str
    name: str       # what users type
    value: str      # "module:attribute"
    dist: str       # "distribution version", for messages

    def describe(self) -> str:
        return f"{self.group} plugin {self.name!r} ({self.value}, from {self.dist})"

    def load(self) -> Any:
        """Import the plugin's object; any failure is a :class:`PluginError` naming the plugin."""
        module, _, attr = self.value.partition(":")
        try:
            obj = importlib.import_module(module.strip())
            for part in filter(None, attr.strip().split(".")):
                obj = getattr(obj, part)
        except (Exception, SystemExit) as e:  # noqa: BLE001 - whatever a plugin raises at import
            # is its own bug; sys.exit() at import too (it ended navbench silently, exit 0: P-015)
            first = (str(e).strip().splitlines() or [""])[0]
            raise PluginError(f"{self.describe()} failed to load: "
                              f"{type(e).__name__}: {first}".rstrip(": ")) from e
        return obj


def _dist_label(ep: importlib.metadata.EntryPoint) -> str:
    dist = getattr(ep, "dist", None)
    if dist is None:
        return "an unknown distribution"
    try:
        return f"{dist.metadata['Name']} {dist.version}"
    except Exception:  # noqa: BLE001 - broken metadata still deserves a message, not a traceback
        return "an unreadable distribution"


def find_plugins(group: str) -> dict[str, Plugin]:
    """The entry points of ``group`` by name, without importing them.

    The same entry point seen twice (one distribution on ``sys.path`` twice) counts once; two
    different values under one name, or a name that is not a safe name (names become file
    names and database keys), are a :class:`PluginError`.
    """
    found: dict[str, Plugin] = {}
    for ep in importlib.metadata.entry_points(group=group):
        p = Plugin(group, ep.name, ep.value, _dist_label(ep))
        if not is_safe_name(p.name):
            raise PluginError(f"{p.describe()}: the name is not a safe name ({SAFE_NAME_RULE})")
        old = found.get(p.name)
        if old is not None and old.value != p.value:
            raise PluginError(f"{group} plugin name {p.name!r} is declared twice: "
                              f"{old.value} (from {old.dist}) and {p.value} (from {p.dist})")
        found.setdefault(p.name, p)
    return dict(sorted(found.items()))


def load_entry_points(group: str) -> dict[str, Any]:
    """Every plugin of ``group`` imported: ``{name: object}`` (sorted by name); see
    :func:`find_plugins` and :meth:`Plugin.load` for the errors."""
    return {name: p.load() for name, p in find_plugins(group).items()}
