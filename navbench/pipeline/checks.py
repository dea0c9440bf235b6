"""Value checks of profiles and of the options that reach the same settings from the command line
(:mod:`navbench.pipeline.profiles`; ``track-eval -o``): types, ranges, names and the limits.

Every check raises :class:`_Invalid` with what was expected (no location); the caller names the
place (a profile file and field, an option). :func:`check_estimator_options` is the public
entry for estimator options given outside a profile.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Callable

from navbench.errors import ConfigError
from navbench.geometry import MIN_RAY_RANGE, MIN_RAY_STEP
from navbench.names import SAFE_NAME_RULE, is_safe_name

NOISE_NAMES = ("none", "low", "mid", "high", "tracking")
MAP_SOURCES = ("fit", "true", "online", "online-fused")

# Limits (the paper: 5000 views, 10 000 fit steps, 200 tasks, 1 seed, 6 x 3 x 3 cells).
MAX_VIEWS = 100_000          # views per collection
MAX_FIT_STEPS = 1_000_000    # Adam steps of a map fit
MAX_TASKS = 100_000          # tasks per level
MAX_SEEDS = 10_000           # episode seeds per task
MAX_WORKERS = 1024           # worker processes
MAX_EPISODES = 10_000_000    # episodes in one grid
MAX_SEED = 2**63 - 1         # any seed numpy accepts
MAX_GRID_CELLS = 2**28       # cells of a fitted voxel grid (the paper's: 800 000)
#: Largest magnitude of any float setting without its own upper bound (issue 34: ``lr = 1e308``
#: or a tolerance of 1e300 is finite but absurd; it overflows to inf inside a kernel).
MAX_FLOAT = 1e6
#: Smallest lattice spacing (m) of the planner and the localiser: each allocates a lattice over
#: the level (20 m at 1e-9 m would be 4e20 points), so the floor is refused before allocation.
MIN_LATTICE_STEP = 0.01


# ------------------------------------------------------------------------ value checks

class _Invalid(Exception):
    """A value failed its check; the message says what was expected (no location)."""


def _num(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def _describe_range(lo, hi, open_lo: bool, open_hi: bool) -> str:
    if lo is not None and hi is not None:
        return f" in {'(' if open_lo else '['}{_num(lo)}, {_num(hi)}{')' if open_hi else ']'}"
    if lo is not None:
        return f" {'>' if open_lo else '>='} {_num(lo)}"
    if hi is not None:
        return f" {'<' if open_hi else '<='} {_num(hi)}"
    return ""


@dataclass(frozen=True)
class Num:
    """A number's type and range: ``kind`` "int" or "float" (a float field accepts integers)."""

    kind: str = "float"
    lo: float | None = None
    hi: float | None = None
    open_lo: bool = False
    open_hi: bool = False

    def check(self, v: Any) -> None:
        what = ("an integer" if self.kind == "int" else "a number") + \
            _describe_range(self.lo, self.hi, self.open_lo, self.open_hi)
        ok_type = isinstance(v, int) if self.kind == "int" else isinstance(v, (int, float))
        if isinstance(v, bool) or not ok_type or (isinstance(v, float) and not math.isfinite(v)):
            raise _Invalid(f"expected {what}, got {v!r}")
        if ((self.lo is not None and (v <= self.lo if self.open_lo else v < self.lo))
                or (self.hi is not None and (v >= self.hi if self.open_hi else v > self.hi))):
            raise _Invalid(f"expected {what}, got {v!r}")
        if self.kind == "float" and abs(v) > MAX_FLOAT:  # finite but absurd (issue 34)
            raise _Invalid(f"expected {what} of magnitude at most {MAX_FLOAT:g}, got {v!r}")


def _int(lo=0, hi=None) -> Num:
    return Num("int", lo, hi)


def _pos(kind="float") -> Num:
    return Num(kind, 0, None, open_lo=True)


_SEED = _int(0, MAX_SEED)


def _check_map_source(v: Any) -> None:
    """fit, true, or a map file path (``.npz``; ``{level}`` stands for the level's name)."""
    _check_str(v)
    if v not in MAP_SOURCES and not v.endswith(".npz"):
        raise _Invalid(f"unknown value {v!r}; choose one of {list(MAP_SOURCES)} or give a map file "
                       "path ending in .npz ({level} stands for the level's name)")


def _check_str(v: Any, choices: tuple[str, ...] | None = None) -> None:
    if not isinstance(v, str):
        raise _Invalid(f"expected a string, got {v!r}")
    if choices is not None and v not in choices:
        from navbench.names import did_you_mean

        raise _Invalid(f"unknown value {v!r}{did_you_mean(v, choices)}; choose one of {list(choices)}")


def _check_names(v: Any, kind: str, known: Callable[[], list[str]] | None) -> None:
    """A non-empty list of distinct names; each safe, and one of ``known()`` when given."""
    if not isinstance(v, (list, tuple)) or not all(isinstance(x, str) for x in v):
        raise _Invalid(f"expected a list of {kind} names, got {v!r}")
    if not v:
        raise _Invalid(f"expected at least one {kind} name, got an empty list")
    names = known() if known is not None else None
    seen = set()
    for x in v:
        if names is not None and x not in names:
            from navbench.names import did_you_mean

            raise _Invalid(f"unknown {kind} {x!r}{did_you_mean(x, names)} (known: {', '.join(names)})")
        if not is_safe_name(x):
            raise _Invalid(f"{x!r} is not a safe {kind} name ({SAFE_NAME_RULE})")
        if x in seen:
            raise _Invalid(f"{kind} {x!r} is listed twice")
        seen.add(x)


def _known_estimators() -> list[str]:
    from navbench.track.registry import known_estimators

    return known_estimators()


def _check_estimators(v: Any) -> None:
    """Estimator names (built-in or plugin, see :mod:`navbench.track.registry`), each class
    loaded now: a broken plugin fails here, before any stage runs, not in a worker."""
    _check_names(v, "estimator", _known_estimators)
    from navbench.errors import PluginError
    from navbench.track.registry import estimator_class

    for name in v:
        try:
            estimator_class(name)
        except PluginError as e:
            raise _Invalid(str(e)) from None


# ------------------------------------------------------ dataclass-valued tables (fit, episode, options)

#: Ranges of FitConfig fields (navbench.worldmodel.fit). ``steps`` and ``seed`` are the profile's
#: own ``[fit] steps`` / ``[fit] seed``. Fields not listed: numbers >= 0, strings as FitConfig checks.
FIT_RANGES: dict[str, Any] = {
    "lr": Num(lo=0, hi=10, open_lo=True), "sigma2_init": _pos(), "sigma2_lr": Num(lo=0, hi=10),
    "min_sigma2": _pos(),
    "images_per_batch": _int(1, 100_000), "pixels_per_image": _int(1, 1_000_000),
    "grid_shape": _int(1, 65_536), "margin_z": Num(lo=0), "max_range": Num(lo=MIN_RAY_RANGE),
    "n_samples": _int(1, 100_000), "tau": Num(lo=0, hi=1, open_lo=True, open_hi=True),
    "init_free": Num(lo=0, hi=1), "init_solid": Num(lo=0, hi=1), "init_colour": Num(lo=0, hi=1),
    "free_space_weight": Num(lo=0), "free_space_samples": _int(0, 1000),
    "free_space_margin": Num(lo=0), "free_space_delta": Num(lo=0),
    "threads": _int(1, MAX_WORKERS), "init": ("box", "empty"), "optimizer": ("adam", "lazy-adam"),
}
#: Ranges of EpisodeConfig fields (navbench.nav.episode) and of its planner/controller tables.
EPISODE_RANGES: dict[str, Any] = {
    "max_steps": _int(1, 1_000_000), "goal_tolerance": _pos(), "max_replans": _int(0, 1_000_000),
    "planner.step": Num(lo=MIN_LATTICE_STEP, hi=10), "planner.goal_tolerance": _pos(), "planner.edge_samples": _int(1, 100_000),
    "planner.max_expansions": _int(1, 100_000_000),
    "controller.heading_threshold": _pos(), "controller.waypoint_tolerance": _pos(),
    "controller.lookahead": _int(1, 100_000), "controller.max_turn": _pos(), "controller.max_step": _pos(),
    "pose_quantisation": ("off", "round", "truncate"), "collision_check": ("swept", "endpoint"),
    "texture": ("procedural", "table", "polynomial"),  # navbench.sim.texels.TEXTURE_MODES
}
#: Ranges of estimator options (TrackerConfig of ours/no-map, EmissionConfig of emission).
OPTION_RANGES: dict[str, Any] = {
    "optimizer": ("adam", "gauss-newton"), "param": ("planar", "se3"),
    "adam_steps": _int(1, 100_000), "adam_pixels": _int(1, 1_000_000), "gn_iters": _int(1, 100_000),
    "gn_geo_iters": _int(0, 100_000), "gn_pixels": _int(1, 1_000_000),
    "yaw_search_pixels": _int(0, 1_000_000), "prior_sigma": _pos(), "off_plane_sigma": _pos(),
    "steps": _int(1, 100_000), "pixels": _int(1, 1_000_000), "threads": _int(1, MAX_WORKERS),
    "sigma2": _pos(), "default_sigma2": _pos(), "step": Num(lo=MIN_RAY_STEP), "max_range": Num(lo=MIN_RAY_RANGE),
    "pixel_scale": _pos(),
}
#: Ranges of LocalizerConfig fields (navbench.localize; ``[navigation] goal_localizer`` and
#: ``localize-eval -o``). Fields not listed: numbers >= 0 (floats at most MAX_FLOAT).
LOCALIZER_RANGES: dict[str, Any] = {
    "lattice_step": Num(lo=MIN_LATTICE_STEP, hi=10), "bins": _int(4, 4096), "rows": _int(1, 64),
    "k": _int(1, 1000), "max_candidates": _int(1, 100_000), "min_candidates": _int(0, 100_000),
    "truncate_top": _int(0, 10_000_000), "refine_rounds": _int(0, 1000),
    "refine_stride": _int(1, 64), "gn_pixels": _int(1, 1_000_000), "feature_range": _pos(),
    "row_top": Num(lo=-10, hi=10), "row_step": Num(lo=-10, hi=10),
    "depth_feature": ("range", "inverse"),
}


def _check_typed(v: Any, tp: Any, rng: Any) -> None:
    """Check ``v`` against the resolved annotation ``tp`` (int, float, str, bool, fixed-length
    tuples, ``X | None``) and the range ``rng`` (a :class:`Num`, or a tuple of string choices)."""
    import types
    import typing

    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if v is None:
            return
        if len(args) > 1:  # e.g. float | str (a number or "auto"): the first member that fits
            errors = []
            for a in args:
                try:
                    return _check_typed(v, a, rng)
                except _Invalid as e:
                    errors.append(str(e))
            raise _Invalid(" or ".join(errors))
        tp, origin = args[0], typing.get_origin(args[0])
    if tp is bool:
        if not isinstance(v, bool):
            raise _Invalid(f"expected true or false, got {v!r}")
    elif tp is str:
        _check_str(v, rng if isinstance(rng, tuple) else None)
    elif tp in (int, float):
        (rng if isinstance(rng, Num) else Num(tp.__name__, lo=0)).check(v)
    elif origin is tuple:
        args = typing.get_args(tp)
        n = len(args)
        if not isinstance(v, (list, tuple)) or len(v) != n:
            raise _Invalid(f"expected a list of {n} numbers, got {v!r}")
        for i, (x, a) in enumerate(zip(v, args)):
            try:
                (rng if isinstance(rng, Num) else Num(a.__name__, lo=0)).check(x)
            except _Invalid as e:
                raise _Invalid(f"[{i}]: {e}") from None
    else:
        raise _Invalid(f"cannot be set from a profile (type {tp})")


def _check_table(cls: type, values: Any, ranges: dict[str, Any], prefix: str = "") -> None:
    """Check a TOML table against dataclass ``cls`` (nested ones: tables); errors name the dotted path."""
    import typing

    if not isinstance(values, dict):
        raise _Invalid(f"{prefix.rstrip('.') or 'value'}: expected a table, got {values!r}")
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    for k, v in values.items():
        path = f"{prefix}{k}"
        if k not in names:
            raise _Invalid(f"{path}: unknown field; known: {names}")
        tp = hints[k]
        if dataclasses.is_dataclass(tp):
            _check_table(tp, v, ranges, f"{path}.")
            continue
        try:
            _check_typed(v, tp, ranges.get(path))
        except _Invalid as e:
            raise _Invalid(f"{path}: {e}") from None


def _check_fit(fit: Any) -> None:
    """``[fit]`` extras: FitConfig fields, types and ranges (numba only then), then FitConfig's checks."""
    if not isinstance(fit, dict):
        raise _Invalid(f"expected a table, got {fit!r}")
    if not fit:
        return
    from navbench.worldmodel.fit import FitConfig

    for own in ("steps", "seed"):
        if own in fit:
            raise _Invalid(f"{own}: set it as the profile's [fit] {own}")
    _check_table(FitConfig, fit, FIT_RANGES)
    if "grid_shape" in fit and math.prod(fit["grid_shape"]) > MAX_GRID_CELLS:
        raise _Invalid(f"grid_shape: {math.prod(fit['grid_shape'])} cells; at most {MAX_GRID_CELLS}")
    try:
        FitConfig(**fit)
    except ConfigError as e:
        raise _Invalid(str(e).removeprefix("fit: ")) from None


def _check_goal_localizer(overrides: Any) -> None:
    """``[navigation] goal_localizer``: fields of :class:`navbench.localize.LocalizerConfig`
    with their types (the image-goal stage's goal search, issue 15); ``k`` is the stage's own."""
    if not isinstance(overrides, dict):
        raise _Invalid(f"expected a table of localiser settings, got {overrides!r}")
    if not overrides:
        return
    from navbench.localize import LocalizerConfig

    if "k" in overrides:
        raise _Invalid("k: the image-goal stage asks for two hypotheses; it is not a setting")
    _check_table(LocalizerConfig, overrides, LOCALIZER_RANGES)
    for k, v in overrides.items():  # a field with a range of its own (row_top: -0.3) says its bounds
        if k not in LOCALIZER_RANGES and isinstance(v, (int, float)) and not isinstance(v, bool) and v < 0:
            raise _Invalid(f"{k}: must be >= 0, got {v!r}")


def _check_episode(episode: Any) -> None:
    if not isinstance(episode, dict):
        raise _Invalid(f"expected a table, got {episode!r}")
    if not episode:
        return
    from navbench.nav.episode import EpisodeConfig

    _check_table(EpisodeConfig, episode, EPISODE_RANGES)


def _check_options(options: Any, section_of: Callable[[str], str] | None = None, sep: str = " ") -> None:
    """``[navigation.options.<estimator>]``: known estimators, only the options their
    constructors accept (with types and ranges); ``seed`` belongs to the pipeline.
    ``section_of(estimator)`` starts each message (default ``[navigation.options.<estimator>]``),
    ``sep`` joins it to an option's name."""
    if not isinstance(options, dict):
        raise _Invalid(f"expected a table of estimator tables, got {options!r}")
    if not options:
        return
    from navbench.errors import NavbenchError
    from navbench.track.registry import estimator_options_config

    known = _known_estimators()
    for est, opts in options.items():
        section = section_of(est) if section_of is not None else f"[navigation.options.{est}]"
        if est not in known:
            from navbench.names import did_you_mean

            raise _Invalid(f"{section}: unknown estimator {est!r}{did_you_mean(est, known)} (known: {', '.join(known)})")
        if not isinstance(opts, dict):
            raise _Invalid(f"{section}: expected a table of options, got {opts!r}")
        for reserved in ("seed", "vmap", "intrinsics", "camera_height", "renderer"):
            if reserved in opts:
                raise _Invalid(f"{section}{sep}{reserved}: set by the pipeline for every episode "
                               "(the estimator seed derives from the task and episode seed); remove it")
        cfg_cls = estimator_options_config(est)
        if cfg_cls is None:
            if opts:
                raise _Invalid(f"{section}: the {est!r} estimator takes no options, got {sorted(opts)}")
            continue
        if section_of is None and opts.get("health_min_inliers") == "auto":
            raise _Invalid(f"{section}{sep}health_min_inliers: 'auto' (the map's calibrated threshold) is "
                           "computed by track-eval only; give a number in [0, 1] for navigation runs")
        try:
            _check_table(cfg_cls, opts, OPTION_RANGES)
            from navbench.track.base import config_from_options

            config_from_options(cfg_cls(), opts, est)
        except _Invalid as e:
            raise _Invalid(f"{section}{sep}{e}") from None
        except (NavbenchError, ValueError, TypeError) as e:  # a plugin's options may raise these
            raise _Invalid(f"{section}: {e}") from None


def check_localizer_options(options: dict, where: str) -> None:
    """Localiser settings given outside a profile (``localize-eval -o``): the fields of
    :class:`navbench.localize.LocalizerConfig` with the types and :data:`LOCALIZER_RANGES` of
    ``[navigation] goal_localizer``; :class:`ConfigError` naming ``where`` and the setting."""
    from navbench.localize import LocalizerConfig

    try:
        _check_table(LocalizerConfig, options, LOCALIZER_RANGES)
    except _Invalid as e:
        raise ConfigError(f"{where} {e}") from None


def check_estimator_options(options: dict[str, dict], where: str) -> None:
    """Estimator options given outside a profile (``track-eval -o``): the checks of
    ``[navigation.options.<estimator>]`` (known estimators, only their options, types, ranges,
    the estimator's own checks; ``seed`` and the other pipeline-set names refused).
    :class:`ConfigError` naming ``where`` and the estimator."""
    try:
        _check_options(options, lambda est: f"{where} {est}", sep=".")
    except _Invalid as e:
        raise ConfigError(str(e)) from None
