"""Profiles: named TOML bundles of stage settings (``navbench/profiles/<name>.toml``).

A profile fixes everything ``navbench all`` needs: levels, views, fit, tasks and the navigation
grid. CLI options override single fields (:func:`override`). A profile argument is either a
bundled name (``quick``, ``paper``) or a path to a ``.toml`` file of the same layout::

    name = "quick"
    levels = ["house-1"]
    level_seed = 1
    [views]       camera, count, seed, eval_count, eval_seed
    [fit]         steps, seed, and optionally any other FitConfig field
    [tasks]       count, seed, difficulty (NRNS names: count tasks of each; issue 15)
    [navigation]  estimators, noise, seeds, workers (0 = CPU count), map ("fit" or "true"),
                  goal ("point" or "image"), and optional
                  [navigation.episode] (EpisodeConfig fields) and
                  [navigation.options.<estimator>] (estimator keyword arguments)
    [conditions]  the paper's simulator conditions by name (navbench.sim.conditions), e.g.
                  pose_quantisation = "round"; they set [navigation.episode] fields
    [scoring]     preset: "paper", "nrns" or "habitat" (navbench.nav.presets)

Unknown keys are errors (a typo must not silently fall back to a default). Every field is
checked for its type and range when the profile is loaded and again after CLI overrides, so a
bad value fails before any stage runs, with a message naming the file (or option) and the field:
``tiny.toml: [fit] steps: expected an integer in [1, 1000000], got 'fifty'``. Values are kept
as written (an integer ``lr = 1`` stays an integer), so the cache keys of valid profiles do not
change. Booleans are not integers here (TOML ``true`` for a count is an error).

Sizes are bounded (generous limits, far above the paper's protocol) so that a typo cannot plan
or allocate without end: at most :data:`MAX_EPISODES` episodes in a grid (levels x estimators x
noise x tasks x seeds), and the per-field maxima below.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import functools
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from navbench.errors import ConfigError
from navbench.geometry import CAMERA_NAMES
from navbench.nav.presets import DIFFICULTY_BANDS, PRESETS, check_preset_steps

PROFILES_DIR = Path(__file__).resolve().parent.parent / "profiles"
DEFAULT_PROFILE = "quick"
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

_SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
_SAFE_RULE = ("letters, digits, '_', '.', '-', starting with a letter or digit, at most 64 "
              "characters, no '..'")


def is_safe_name(name: Any) -> bool:
    """Whether ``name`` matches ``^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$`` and holds no ``..``."""
    return isinstance(name, str) and bool(_SAFE_NAME.fullmatch(name)) and ".." not in name


def check_name(name: Any, what: str) -> str:
    """``name`` if it is a safe name (it becomes part of file names: profile refs, levels/NAME.json);
    else :class:`ConfigError` naming ``what``. Safe: letters, digits, ``_ . -``, starting with a
    letter or digit, at most 64 characters, no ``..``."""
    if not is_safe_name(name):
        raise ConfigError(f"{what}: {name!r} is not a safe name ({_SAFE_RULE})")
    return name


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
        raise _Invalid(f"unknown value {v!r}; choose one of {list(choices)}")


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
            raise _Invalid(f"unknown {kind} {x!r} (known: {', '.join(names)})")
        if not is_safe_name(x):
            raise _Invalid(f"{x!r} is not a safe {kind} name ({_SAFE_RULE})")
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
    "lr": _pos(), "sigma2_init": _pos(), "sigma2_lr": Num(lo=0), "min_sigma2": _pos(),
    "images_per_batch": _int(1, 100_000), "pixels_per_image": _int(1, 1_000_000),
    "grid_shape": _int(1, 65_536), "margin_z": Num(lo=0), "max_range": _pos(),
    "n_samples": _int(1, 100_000), "tau": Num(lo=0, hi=1, open_lo=True, open_hi=True),
    "init_free": Num(lo=0, hi=1), "init_solid": Num(lo=0, hi=1), "init_colour": Num(lo=0, hi=1),
    "free_space_weight": Num(lo=0), "free_space_samples": _int(0, 1000),
    "free_space_margin": Num(lo=0), "free_space_delta": Num(lo=0),
    "threads": _int(1, MAX_WORKERS), "init": ("box", "empty"), "optimizer": ("adam", "lazy-adam"),
}
#: Ranges of EpisodeConfig fields (navbench.nav.episode) and of its planner/controller tables.
EPISODE_RANGES: dict[str, Any] = {
    "max_steps": _int(1, 1_000_000), "goal_tolerance": _pos(), "max_replans": _int(0, 1_000_000),
    "planner.step": _pos(), "planner.goal_tolerance": _pos(), "planner.edge_samples": _int(1, 100_000),
    "planner.max_expansions": _int(1, 100_000_000),
    "controller.heading_threshold": _pos(), "controller.waypoint_tolerance": _pos(),
    "controller.lookahead": _int(1, 100_000), "controller.max_turn": _pos(), "controller.max_step": _pos(),
    "pose_quantisation": ("off", "round", "truncate"), "collision_check": ("swept", "endpoint"),
}
#: Ranges of estimator options (TrackerConfig of ours/no-map, EmissionConfig of emission).
OPTION_RANGES: dict[str, Any] = {
    "optimizer": ("adam", "gauss-newton"), "param": ("planar", "se3"),
    "adam_steps": _int(1, 100_000), "adam_pixels": _int(1, 1_000_000), "gn_iters": _int(1, 100_000),
    "gn_geo_iters": _int(0, 100_000), "gn_pixels": _int(1, 1_000_000),
    "yaw_search_pixels": _int(0, 1_000_000), "prior_sigma": _pos(), "off_plane_sigma": _pos(),
    "steps": _int(1, 100_000), "pixels": _int(1, 1_000_000), "threads": _int(1, MAX_WORKERS),
    "sigma2": _pos(), "default_sigma2": _pos(), "step": _pos(), "max_range": _pos(),
    "pixel_scale": _pos(),
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


def _check_episode(episode: Any) -> None:
    if not isinstance(episode, dict):
        raise _Invalid(f"expected a table, got {episode!r}")
    if not episode:
        return
    from navbench.nav.episode import EpisodeConfig

    _check_table(EpisodeConfig, episode, EPISODE_RANGES)


def _check_options(options: Any) -> None:
    """``[navigation.options.<estimator>]``: known estimators, only the options their
    constructors accept (with types and ranges); ``seed`` belongs to the pipeline."""
    if not isinstance(options, dict):
        raise _Invalid(f"expected a table of estimator tables, got {options!r}")
    if not options:
        return
    from navbench.errors import NavbenchError
    from navbench.track.registry import estimator_options_config

    known = _known_estimators()
    for est, opts in options.items():
        section = f"[navigation.options.{est}]"
        if est not in known:
            raise _Invalid(f"{section}: unknown estimator {est!r} (known: {', '.join(known)})")
        if not isinstance(opts, dict):
            raise _Invalid(f"{section}: expected a table of options, got {opts!r}")
        for reserved in ("seed", "vmap", "intrinsics", "camera_height", "renderer"):
            if reserved in opts:
                raise _Invalid(f"{section} {reserved}: set by the pipeline for every episode "
                               "(the estimator seed derives from the task and episode seed); remove it")
        cfg_cls = estimator_options_config(est)
        if cfg_cls is None:
            if opts:
                raise _Invalid(f"{section}: the {est!r} estimator takes no options, got {sorted(opts)}")
            continue
        try:
            _check_table(cfg_cls, opts, OPTION_RANGES)
            from navbench.track.base import config_from_options

            config_from_options(cfg_cls(), opts, est)
        except _Invalid as e:
            raise _Invalid(f"{section} {e}") from None
        except (NavbenchError, ValueError, TypeError) as e:  # a plugin's options may raise these
            raise _Invalid(f"{section}: {e}") from None


# ------------------------------------------------------------------------ the profile

@dataclass(frozen=True)
class Profile:
    """The resolved settings of one profile (units in the comments)."""

    name: str
    description: str = ""
    levels: tuple[str, ...] = ("house-1",)
    level_seed: int | None = None    # levelgen seed of the profile's levels without levels/NAME.json (None: such a level is an error)
    camera: str = "half"             # camera of views, simulator and estimators
    views: int = 1000                # training views per level
    views_seed: int = 0              # pose sampling seed of the training views
    eval_views: int = 200            # held-out views for map quality
    eval_seed: int = 1               # pose sampling seed of the held-out views
    fit_steps: int = 200             # Adam steps of the map fit
    fit_seed: int = 0                # batch sampling seed of the fit
    fit: dict = field(default_factory=dict)        # other FitConfig fields
    tasks: int = 30                  # tasks per level
    tasks_seed: int = 0              # task sampling seed
    estimators: tuple[str, ...] = ("ours", "no-map", "dynamics")
    noise: tuple[str, ...] = ("mid",)
    seeds: int = 1                   # episode seeds per task
    workers: int = 0                 # local worker processes, 0 = CPU count
    map_source: str = "fit"          # "fit": fitted world model; "true": voxelized true geometry; or a .npz path
    episode: dict = field(default_factory=dict)    # EpisodeConfig fields
    estimator_options: dict = field(default_factory=dict)  # estimator -> keyword arguments
    tasks_difficulty: tuple[str, ...] = ()  # NRNS difficulties, [tasks] count of each (issue 15)
    goal: str = "point"              # "point" (coordinates) or "image" (the goal image; issue 15)
    scoring_preset: str = "paper"    # navbench.nav.presets: paper, nrns, habitat

    def __post_init__(self):
        validate(self, _WHERE.get())


_WHERE: "contextvars.ContextVar[str | None]" = contextvars.ContextVar("profile_where", default=None)


@contextlib.contextmanager
def _validating_as(where: str):
    """Name ``where`` (the file, or "command line") in the messages of Profile's own validation."""
    token = _WHERE.set(where)
    try:
        yield
    finally:
        _WHERE.reset(token)


#: Profile field -> (its place in the TOML file, its check). The check raises :class:`_Invalid`.
FIELDS: dict[str, tuple[str, Callable[[Any], None]]] = {
    "name": ("name", lambda v: _check_names([v], "profile", None)),
    "description": ("description", _check_str),
    "levels": ("levels", lambda v: _check_names(v, "level", None)),
    "level_seed": ("level_seed", lambda v: None if v is None else _SEED.check(v)),
    "camera": ("[views] camera", lambda v: _check_str(v, CAMERA_NAMES)),
    "views": ("[views] count", _int(1, MAX_VIEWS).check),
    "views_seed": ("[views] seed", _SEED.check),
    "eval_views": ("[views] eval_count", _int(1, MAX_VIEWS).check),
    "eval_seed": ("[views] eval_seed", _SEED.check),
    "fit_steps": ("[fit] steps", _int(1, MAX_FIT_STEPS).check),
    "fit_seed": ("[fit] seed", _SEED.check),
    "fit": ("[fit]", _check_fit),
    "tasks": ("[tasks] count", _int(1, MAX_TASKS).check),
    "tasks_seed": ("[tasks] seed", _SEED.check),
    "estimators": ("[navigation] estimators", _check_estimators),
    "noise": ("[navigation] noise", lambda v: _check_names(v, "noise level", lambda: list(NOISE_NAMES))),
    "seeds": ("[navigation] seeds", _int(1, MAX_SEEDS).check),
    "workers": ("[navigation] workers", _int(0, MAX_WORKERS).check),
    "map_source": ("[navigation] map", lambda v: _check_map_source(v)),
    "episode": ("[navigation.episode]", _check_episode),
    "estimator_options": ("", _check_options),  # its messages name [navigation.options.<estimator>]
    "tasks_difficulty": ("[tasks] difficulty", lambda v: v == () or _check_names(v, "difficulty", lambda: list(DIFFICULTY_BANDS))),
    "goal": ("[navigation] goal", lambda v: _check_str(v, ("point", "image"))),
    "scoring_preset": ("[scoring] preset", lambda v: _check_str(v, tuple(PRESETS))),
}

#: Fields holding a table: their messages continue the section label with the table's own field.
_TABLE_FIELDS = ("fit", "episode", "estimator_options")

#: The CLI option that overrides a profile field (named in messages about overridden values).
OPTION_NAMES = {"levels": "LEVELS", "estimators": "--estimators", "noise": "--noise",
                "tasks": "--tasks", "seeds": "--seeds", "workers": "--workers", "map_source": "--map",
                "fit_steps": "--steps", "fit_seed": "--seed", "camera": "--camera", "goal": "--goal", "scoring_preset": "--preset"}


def check_field(fname: str, value: Any, where: str, label: str | None = None) -> None:
    """Check one profile field; :class:`ConfigError` ``"<where>: <label>: <what was expected>"``."""
    default_label, check = FIELDS[fname]
    label = label or default_label
    try:
        check(value)
    except _Invalid as e:
        sep = " " if fname in _TABLE_FIELDS else ": "
        raise ConfigError(f"{where}: {label}{sep}{e}".replace(":  ", ": ")) from None


def validate(p: Profile, where: str | None = None) -> None:
    """Raise :class:`ConfigError` for any field of the wrong type or out of range, and for
    inconsistent fields (held-out views = training views, a grid beyond :data:`MAX_EPISODES`)."""
    where = where or f"profile {p.name!r}"
    for f in dataclasses.fields(Profile):
        check_field(f.name, getattr(p, f.name), where)
    if p.eval_seed == p.views_seed:
        raise ConfigError(f"{where}: [views] eval_seed must differ from [views] seed "
                          "(the held-out views must not be the training views)")
    check_preset_steps(p.scoring_preset, p.episode.get("max_steps", 500), where)
    check_grid_size(p, where)


def grid_size(p: Profile) -> int:
    """Episodes in the profile's grid: levels x estimators x noise x tasks x seeds."""
    return len(dict.fromkeys(p.levels)) * len(p.estimators) * len(p.noise) * p.tasks * max(1, len(p.tasks_difficulty)) * p.seeds


def check_grid_size(p: Profile, where: str) -> None:
    n = grid_size(p)
    if n > MAX_EPISODES:
        raise ConfigError(
            f"{where}: the grid has {n:,} episodes ({len(dict.fromkeys(p.levels))} levels x "
            f"{len(p.estimators)} estimators x {len(p.noise)} noise x {p.tasks} tasks x {p.seeds} "
            f"seeds); at most {MAX_EPISODES:,} are allowed")


_SECTIONS: dict[str, dict[str, str]] = {
    "": {"name": "name", "description": "description", "levels": "levels", "level_seed": "level_seed"},
    "views": {"camera": "camera", "count": "views", "seed": "views_seed",
              "eval_count": "eval_views", "eval_seed": "eval_seed"},
    "fit": {"steps": "fit_steps", "seed": "fit_seed"},
    "tasks": {"count": "tasks", "seed": "tasks_seed", "difficulty": "tasks_difficulty"},
    "navigation": {"estimators": "estimators", "noise": "noise", "seeds": "seeds",
                   "workers": "workers", "map": "map_source", "episode": "episode",
                   "options": "estimator_options", "goal": "goal"},
    "scoring": {"preset": "scoring_preset"},
    "conditions": {},  # navbench.sim.conditions: set into [navigation.episode] on loading
}


def profile_from_dict(doc: dict[str, Any], source: str = "<profile>") -> Profile:
    """Build a :class:`Profile` from a parsed TOML document; unknown keys and bad values are
    :class:`ConfigError` naming ``source`` and the field."""
    kw: dict[str, Any] = {}
    fit_extra: dict[str, Any] = {}
    for key, value in doc.items():
        if key in _SECTIONS and key != "":
            if not isinstance(value, dict):
                raise ConfigError(f"{source}: [{key}] must be a table")
            for k, v in value.items():
                if key == "fit" and k not in _SECTIONS["fit"]:
                    fit_extra[k] = v
                    continue
                if key == "conditions":
                    kw.setdefault("conditions", {})[k] = v
                    continue
                if k not in _SECTIONS[key]:
                    raise ConfigError(f"{source}: unknown key {key}.{k}")
                kw[_SECTIONS[key][k]] = v
        elif key in _SECTIONS[""]:
            kw[_SECTIONS[""][key]] = value
        else:
            raise ConfigError(f"{source}: unknown key {key!r}")
    if "name" not in kw:
        raise ConfigError(f"{source}: missing 'name'")
    if "conditions" in kw:  # [conditions] NAME = "VALUE": EpisodeConfig fields by their paper names
        from navbench.sim.conditions import merge_conditions

        check_field("episode", kw.get("episode", {}), source)
        kw["episode"] = merge_conditions(kw.get("episode", {}), kw.pop("conditions"), f"{source}: [conditions]")
    kw["fit"] = fit_extra
    for fname, value in kw.items():  # in file order, each message naming the file and field
        check_field(fname, value, source)
    for k in ("levels", "estimators", "noise", "tasks_difficulty"):
        if k in kw:
            kw[k] = tuple(kw[k])
    with _validating_as(source):
        return Profile(**kw)


def available_profiles() -> list[str]:
    """Names of the bundled profiles."""
    return sorted(p.stem for p in PROFILES_DIR.glob("*.toml"))


def load_profile(name_or_path: str | None = None) -> Profile:
    """Load a bundled profile by name, or a TOML file by path (default: ``quick``)."""
    name_or_path = name_or_path or DEFAULT_PROFILE
    p = Path(name_or_path)
    if p.suffix == ".toml" and p.is_file():
        path = p
    else:
        path = PROFILES_DIR / f"{name_or_path}.toml"
        if not is_safe_name(name_or_path) or not path.is_file():
            raise ConfigError(f"--profile: unknown profile {name_or_path!r}; choose one of "
                              f"{available_profiles()} or give the path of a .toml file")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not valid TOML ({e})") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not valid TOML (not UTF-8 text)") from None
    except OSError as e:
        raise ConfigError(f"{path}: cannot read the profile ({e.strerror or e})") from None
    return profile_from_dict(doc, str(path))


def override(profile: Profile, **changes: Any) -> Profile:
    """A copy of ``profile`` with the non-``None`` ``changes`` applied (CLI options); each
    changed value is checked and a bad one is reported under its option's name."""
    changes = {k: v for k, v in changes.items() if v is not None}
    unknown = set(changes) - {f.name for f in dataclasses.fields(Profile)}
    if unknown:
        raise ConfigError(f"unknown profile field(s): {sorted(unknown)}")
    for k, v in changes.items():
        check_field(k, v, "command line", OPTION_NAMES.get(k, k))
    for k in ("levels", "estimators", "noise"):
        if k in changes:
            changes[k] = tuple(changes[k])
    if not changes:
        return profile
    with _validating_as("command line"):
        return dataclasses.replace(profile, **changes)


@functools.lru_cache(maxsize=1)
def _bundled_docs() -> tuple[tuple[str, dict], ...]:
    """``(name, parsed TOML)`` of every readable bundled profile, parsed once per process."""
    docs = []
    for name in available_profiles():
        try:
            docs.append((name, tomllib.loads((PROFILES_DIR / f"{name}.toml").read_text(encoding="utf-8"))))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            continue
    return tuple(docs)


def bundled_field_values(fname: str) -> dict[str, Any]:
    """``{profile name: value}`` of the :class:`Profile` field ``fname`` in every bundled profile,
    as the TOML file writes it, else the field's default (``fit``: the extra FitConfig fields).
    For help texts: unchecked and cheap (no numba), read once per process, values shared (treat
    them as read-only); an unreadable bundled file is left out (loading it reports the error)."""
    if fname == "fit":
        section, key = "fit", None
    else:
        section, key = next((s, k) for s, keys in _SECTIONS.items() for k, f in keys.items() if f == fname)
    default = next(f for f in dataclasses.fields(Profile) if f.name == fname)
    out: dict[str, Any] = {}
    for name, doc in _bundled_docs():
        table = doc.get(section, {}) if section else doc
        table = table if isinstance(table, dict) else {}
        if key is None:
            out[name] = {k: v for k, v in table.items() if k not in _SECTIONS["fit"]}
        elif key in table:
            out[name] = table[key]
        else:
            out[name] = default.default_factory() if default.default is dataclasses.MISSING else default.default
    return out
