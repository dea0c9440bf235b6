"""The estimator registry: names -> estimator classes, built-in and from plugins.

Built-in estimators are listed in :data:`BUILTIN_ESTIMATORS` and imported when this module is
imported: they are part of navbench, so a failing import is a bug and surfaces as what it is
(an ``ImportError`` with its traceback), never as an "unknown estimator". Plugin estimators are
the entry points of the group ``navbench.estimators`` (:mod:`navbench.plugins`): their names are
read on first use, each class is imported when it is first looked up, and a failing import is a
one-line :class:`~navbench.errors.PluginError` naming the plugin and its distribution. A plugin
whose name is a built-in's is an error (it would silently change what the name means).

Every process that builds estimators (the parent, each pool or Ray worker) goes through
:func:`make_estimator` here, so workers find plugins the same way the parent does, from the
``sys.path`` they inherit.

What an estimator needs besides the pose-estimator interface (:mod:`navbench.track.base`) is
declared as class attributes, read by :func:`uses_frames`, :func:`uses_map` and
:func:`estimator_options_config`:

``uses_frames: bool``
    whether it reads camera images; when False the simulator renders none (``gt``, ``dynamics``).
``uses_map: bool``
    whether it needs the world model (``vmap``).
``options: type | None``
    the frozen dataclass whose fields are the keyword options its constructor accepts (besides
    the pipeline's ``vmap``, ``intrinsics``, ``camera_height``, ``renderer`` and ``seed``), so
    a profile's ``[navigation.options.<name>]`` is checked before any episode runs; ``None``:
    it takes none.
"""

from __future__ import annotations

import importlib
from dataclasses import is_dataclass
from typing import Any, Iterable

import numpy as np

from navbench.errors import ConfigError, PluginError, TrackingError
from navbench.plugins import ESTIMATORS_GROUP, Plugin, find_plugins

#: Built-in estimators: name -> "module:Class" (the form of a plugin's entry point).
BUILTIN_ESTIMATORS = {
    "gt": "navbench.track.basic:GroundTruthEstimator",
    "dynamics": "navbench.track.basic:DynamicsEstimator",
    "ours": "navbench.track.ours:PredictionToObservationTracker",
    "no-map": "navbench.track.ours:FrameToFrameTracker",
    "emission": "navbench.track.emission:EmissionTracker",
}

#: Capability attributes and their types (see the module docstring).
CAPABILITIES = {"uses_frames": bool, "uses_map": bool}


def _import_builtin(spec: str) -> type:
    module, cls = spec.split(":")
    return getattr(importlib.import_module(module), cls)


_CLASSES: dict[str, type] = {name: _import_builtin(spec) for name, spec in BUILTIN_ESTIMATORS.items()}
_PLUGINS: dict[str, Plugin] | None = None


def _plugins() -> dict[str, Plugin]:
    """The plugin entry points by name (read once per process); a clash with a built-in raises."""
    global _PLUGINS
    if _PLUGINS is None:
        found = find_plugins(ESTIMATORS_GROUP)
        for name, p in found.items():
            if name in BUILTIN_ESTIMATORS:
                raise PluginError(f"{p.describe()}: {name!r} is a built-in estimator; "
                                  "rename the entry point")
        _PLUGINS = found
    return _PLUGINS


def reset_plugins() -> None:
    """Forget the plugins found so far (tests; or after installing a plugin in this process)."""
    global _PLUGINS
    _PLUGINS = None
    for name in [n for n in _CLASSES if n not in BUILTIN_ESTIMATORS]:
        del _CLASSES[name]


def known_estimators() -> list[str]:
    """Every estimator name, built-in and plugin, sorted (imports no plugin)."""
    return sorted({*BUILTIN_ESTIMATORS, *_plugins()})


def unknown_estimator(name: Any) -> str:
    """The message for an unknown estimator name: ``unknown estimator 'x' (known: a, b)``."""
    return f"unknown estimator {name!r} (known: {', '.join(known_estimators())})"


def _check_class(p: Plugin, cls: Any) -> type:
    """A plugin's object must be a class declaring valid capabilities (see the module docstring)."""
    if not isinstance(cls, type):
        raise PluginError(f"{p.describe()}: expected an estimator class, got {cls!r}")
    for attr, tp in CAPABILITIES.items():
        if not isinstance(getattr(cls, attr, None), tp):
            raise PluginError(f"{p.describe()}: the class must declare {attr} = True or False")
    opts = getattr(cls, "options", None)
    if opts is not None and not (isinstance(opts, type) and is_dataclass(opts)):
        raise PluginError(f"{p.describe()}: options must be a dataclass (or None), got {opts!r}")
    for method in ("reset", "update"):
        if not callable(getattr(cls, method, None)):
            raise PluginError(f"{p.describe()}: the class has no {method}() method")
    own = getattr(cls, "name", None)
    if own is None:
        cls.name = p.name  # the estimators' messages name themselves by it
    elif own != p.name:
        raise PluginError(f"{p.describe()}: the class says its name is {own!r}; "
                          f"set name = {p.name!r}")
    return cls


def estimator_class(name: str) -> type:
    """The class of estimator ``name`` (a plugin's is imported and checked on first use).

    Raises :class:`TrackingError` (``unknown estimator 'x' (known: ...)``) for an unknown name
    and :class:`PluginError` for a plugin that fails to import or to declare its capabilities.
    """
    cls = _CLASSES.get(name)
    if cls is None:
        p = _plugins().get(name) if isinstance(name, str) else None
        if p is None:
            raise TrackingError(unknown_estimator(name))
        cls = _CLASSES[name] = _guarded(p, _check_class(p, p.load()))
    return cls


def _guarded(p: Plugin, cls: type) -> type:
    """A subclass of plugin class ``cls`` whose constructor, ``reset`` and ``update`` turn what
    the plugin's code raises into one :class:`PluginError` naming the plugin, the method and
    the exception (as a plugin's import failure is): a plugin's bug is not navbench's, and was
    a traceback from every loop that calls it (issue 34, P-012 / P-014). navbench's own errors
    (a :class:`NavbenchError` the plugin lets through) and Ctrl-C pass unchanged."""
    from navbench.errors import NavbenchError

    def guard(method):
        def call(self, *args, **kwargs):
            try:
                out = method(self, *args, **kwargs)
            except NavbenchError:
                raise
            except (Exception, SystemExit) as e:  # noqa: BLE001 - the plugin's own bug
                first = (str(e).strip().splitlines() or [""])[0]
                raise PluginError(f"{p.describe()}: {method.__name__}() raised "
                                  f"{type(e).__name__}: {first}".rstrip(": ")) from e
            if method.__name__ == "update" and not isinstance(getattr(self, "last_timing", None), dict):
                raise PluginError(f"{p.describe()}: update() left no last_timing dict (the "
                                  f"interface of navbench.track.base.Estimator)")
            return out
        call.__name__, call.__doc__ = method.__name__, method.__doc__
        return call

    ns = {m: guard(getattr(cls, m)) for m in ("__init__", "reset", "update")}
    ns.update(__module__=cls.__module__, __qualname__=cls.__qualname__, __doc__=cls.__doc__)
    return type(cls.__name__, (cls,), ns)


def uses_frames(name: str) -> bool:
    """Whether estimator ``name`` reads camera frames (if not, the simulator renders none)."""
    return estimator_class(name).uses_frames


def uses_map(name: str) -> bool:
    """Whether estimator ``name`` needs the world model."""
    return estimator_class(name).uses_map


def estimator_options_config(name: str) -> type | None:
    """The options dataclass of estimator ``name`` (its fields are the accepted options), or
    ``None`` when it accepts none."""
    return estimator_class(name).options


def check_estimator_names(names: Iterable[str], where: str) -> None:
    """Every name known and its class loadable, before any stage runs; else :class:`ConfigError`
    ``"<where>: unknown estimator 'x' (known: ...)"`` (``where``: the option or profile field)
    or the plugin's own :class:`PluginError`."""
    for n in names:
        try:
            estimator_class(n)
        except TrackingError:
            raise ConfigError(f"{where}: {unknown_estimator(n)}") from None


def make_estimator(name: str, **kwargs) -> Any:
    """Build estimator ``name``; ``kwargs`` are its constructor arguments (the pipeline passes
    ``vmap``, ``intrinsics``, ``camera_height``, ``renderer``, ``seed`` and the options)."""
    return estimator_class(name)(**kwargs)


def checked_pose(estimator: Any, out: Any, step: int) -> np.ndarray:
    """The pose an estimator's ``update`` returned at ``step`` (1 = the first update) as a new
    float64 ``(3,)`` array; a :class:`TrackingError` naming the estimator (a plugin: its entry
    point and distribution) when it is not three finite numbers. Every loop that calls
    ``update`` reads its result through here: a NaN pose is never planned on, stored or scored,
    and the error names the estimator, not the database that would refuse the NaN (issue 34)."""
    try:
        pose = np.array(out, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        pose = None
    if pose is None or pose.shape not in ((3,), (1, 3), (3, 1)):
        raise TrackingError(f"{_describe(estimator)}: update() at step {step} returned "
                            f"{repr(out)[:80]}, not a pose (x, y, theta)")
    pose = pose.reshape(3)
    if not np.isfinite(pose).all():
        raise TrackingError(f"{_describe(estimator)}: update() at step {step} returned a "
                            f"non-finite pose {pose.tolist()}")
    return pose


def _describe(estimator: Any) -> str:
    name = getattr(estimator, "name", None)
    if not isinstance(name, str):
        return f"estimator {type(estimator).__name__}"
    plugin = None if name in BUILTIN_ESTIMATORS else _plugins().get(name)
    return plugin.describe() if plugin is not None else f"estimator {name!r}"
