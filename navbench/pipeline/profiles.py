"""Profiles: named TOML bundles of stage settings (``navbench/profiles/<name>.toml``).

A profile fixes everything ``navbench all`` needs: levels, views, fit, tasks and the navigation
grid. CLI options override single fields (:func:`override`). A profile argument is either a
bundled name (``quick``, ``paper``) or a path to a ``.toml`` file of the same layout::

    name = "quick"
    benchmark_version = "navbench-1"   (optional; default navbench.benchmark.BENCHMARK_VERSION)
    levels = ["house-1"]
    level_seed = 1
    sim = "pymunk"   (or "vizdoom": the ViZDoom engine's pose and images; issue 37)
    [views]       camera, count, seed, eval_count, eval_seed, texture
    [fit]         steps, seed, and optionally any other FitConfig field
    [tasks]       count, seed, difficulty (NRNS names: count tasks of each; issue 15)
    [navigation]  estimators, noise, seeds, workers (0 = CPU count), map ("fit" or "true"),
                  goal ("point" or "image"), online_ablation (with map "online*"), and optional
                  [navigation.episode] (EpisodeConfig fields) and
                  [navigation.options.<estimator>] (estimator keyword arguments)
    [conditions]  the paper's simulator conditions by name (navbench.sim.conditions), e.g.
                  pose_quantisation = "round"; they set [navigation.episode] fields
    [scoring]     preset: "paper", "nrns" or "habitat" (navbench.nav.presets)

``benchmark_version`` names the benchmark version the profile runs under: its settings
(:data:`navbench.benchmark.VERSION_SETTINGS`) are the defaults the file is laid over, so every
setting the file writes wins (:mod:`navbench.pipeline.versioning`).

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
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from navbench import benchmark
from navbench.benchmark import SIMULATORS
from navbench.errors import ConfigError
from navbench.geometry import CAMERA_NAMES
from navbench.nav.presets import DIFFICULTY_BANDS, PRESETS, check_preset_steps
from navbench.pipeline.checks import (  # noqa: F401 -- the limits are imported from here too
    _SEED,
    MAX_EPISODES,
    MAX_FIT_STEPS,
    MAX_SEEDS,
    MAX_TASKS,
    MAX_VIEWS,
    MAX_WORKERS,
    NOISE_NAMES,
    _check_estimators,
    _check_episode,
    _check_fit,
    _check_goal_localizer,
    _check_map_source,
    _check_names,
    _check_options,
    _check_str,
    _int,
    _Invalid,
    is_safe_name,
)

PROFILES_DIR = Path(__file__).resolve().parent.parent / "profiles"
DEFAULT_PROFILE = "quick"


# ------------------------------------------------------------------------ the profile

@dataclass(frozen=True)
class Profile:
    """The resolved settings of one profile (units in the comments)."""

    name: str
    description: str = ""
    # benchmark version (navbench.benchmark): a file without the key runs under BENCHMARK_VERSION
    # with that version's settings; a Profile built in Python is navbench-1, whose settings the
    # other fields' defaults are (pipeline.versioning.with_version changes it)
    benchmark_version: str = benchmark.LEGACY_VERSION
    levels: tuple[str, ...] = ("house-1",)
    level_seed: int | None = None    # levelgen seed of the profile's levels without levels/NAME.json (None: such a level is an error)
    camera: str = "half"             # camera of views, simulator and estimators
    views: int = 1000                # training views per level
    views_seed: int = 0              # pose sampling seed of the training views
    views_texture: str = "procedural"  # camera texture mode of the views (navbench.sim.texels)
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
    online_ablation: str = "full"    # --map online*: a Table-4 ablation (stages.online.ABLATIONS)
    goal_localizer: dict = field(default_factory=dict)  # goal = "image": LocalizerConfig overrides of the goal search
    sim: str = "pymunk"              # the simulator: "pymunk" or "vizdoom" (navbench.sim.backends; issue 37)

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


def _online_ablations() -> tuple[str, ...]:
    from navbench.pipeline.stages.online import ABLATIONS

    return ABLATIONS


#: Profile field -> (its place in the TOML file, its check). The check raises :class:`_Invalid`.
FIELDS: dict[str, tuple[str, Callable[[Any], None]]] = {
    "name": ("name", lambda v: _check_names([v], "profile", None)),
    "description": ("description", _check_str),
    "benchmark_version": ("benchmark_version", lambda v: _check_str(v, tuple(benchmark.VERSIONS))),
    "levels": ("levels", lambda v: _check_names(v, "level", None)),
    "level_seed": ("level_seed", lambda v: None if v is None else _SEED.check(v)),
    "camera": ("[views] camera", lambda v: _check_str(v, CAMERA_NAMES)),
    "views": ("[views] count", _int(1, MAX_VIEWS).check),
    "views_seed": ("[views] seed", _SEED.check),
    "views_texture": ("[views] texture", lambda v: _check_str(v, ("procedural", "table", "polynomial"))),
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
    "goal_localizer": ("[navigation] goal_localizer", _check_goal_localizer),
    "scoring_preset": ("[scoring] preset", lambda v: _check_str(v, tuple(PRESETS))),
    "online_ablation": ("[navigation] online_ablation", lambda v: _check_str(v, _online_ablations())),
    "sim": ("sim", lambda v: _check_str(v, SIMULATORS)),
}

#: Fields holding a table: their messages continue the section label with the table's own field.
_TABLE_FIELDS = ("fit", "episode", "estimator_options")

#: The CLI option that overrides a profile field (named in messages about overridden values).
OPTION_NAMES = {"levels": "LEVELS", "estimators": "--estimators", "noise": "--noise",
                "tasks": "--tasks", "seeds": "--seeds", "workers": "--workers", "map_source": "--map",
                "fit_steps": "--steps", "fit_seed": "--seed", "camera": "--camera", "goal": "--goal", "scoring_preset": "--preset",
                "online_ablation": "--online-ablation", "benchmark_version": "--benchmark-version",
                "sim": "--sim"}


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
    if p.sim != "pymunk":  # issue 37: what the engine backend does not cover (yet)
        if p.episode.get("pose_quantisation", "off") != "off":
            raise ConfigError(f"{where}: sim {p.sim}: pose_quantisation must be off (the engine "
                              "quantises the pose itself: to the centimetre and 1/65536 turn); add "
                              "--condition pose_quantisation=off (or --set conditions.pose_quantisation=off)")
        from navbench.results.labels import ONLINE_MAPS

        if p.map_source in ONLINE_MAPS:  # the known-map image goals run on the engine
            raise ConfigError(f"{where}: sim {p.sim}: map {p.map_source!r} (the unknown-house loop) is not "
                              "supported on the engine (its goal image and sensing are the ray-cast "
                              "camera's); use map = \"fit\" or \"true\"")


def ignored_textures_note(p: Profile) -> str | None:
    """The one-line warning when ``p``'s texture modes (views and episodes) do nothing on its
    simulator (:func:`navbench.sim.backends.ignored_textures`), or None."""
    from navbench.sim.backends import ignored_textures

    return ignored_textures(p.sim, p.views_texture, p.episode.get("texture", "procedural"))


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
    "": {"name": "name", "description": "description", "levels": "levels", "level_seed": "level_seed",
         "benchmark_version": "benchmark_version", "sim": "sim"},
    "views": {"camera": "camera", "count": "views", "seed": "views_seed",
              "eval_count": "eval_views", "eval_seed": "eval_seed", "texture": "views_texture"},
    "fit": {"steps": "fit_steps", "seed": "fit_seed"},
    "tasks": {"count": "tasks", "seed": "tasks_seed", "difficulty": "tasks_difficulty"},
    "navigation": {"estimators": "estimators", "noise": "noise", "seeds": "seeds",
                   "workers": "workers", "map": "map_source", "episode": "episode",
                   "options": "estimator_options", "goal": "goal", "online_ablation": "online_ablation",
                   "goal_localizer": "goal_localizer"},
    "scoring": {"preset": "scoring_preset"},
    "conditions": {},  # navbench.sim.conditions: set into [navigation.episode] on loading
}


def profile_from_dict(doc: dict[str, Any], source: str = "<profile>") -> Profile:
    """Build a :class:`Profile` from a parsed TOML document; unknown keys and bad values are
    :class:`ConfigError` naming ``source`` and the field."""
    kw: dict[str, Any] = {}
    fit_extra: dict[str, Any] = {}
    version = doc.get("benchmark_version", benchmark.BENCHMARK_VERSION)
    check_field("benchmark_version", version, source)
    if version != doc.get("benchmark_version"):
        doc = {**doc, "benchmark_version": version}
    doc = _merge(benchmark.settings_document(version), doc)  # the version's settings, under the file's
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


def _read_toml(path: Path) -> dict[str, Any]:
    """The TOML document of a profile file: a regular file of bounded size, bounded nesting and
    finite numbers (:func:`navbench.safeio.load_toml`; a FIFO or a device is refused, never
    read)."""
    from navbench.safeio import load_toml

    return load_toml(path, ConfigError, "profile")


def _is_path(name_or_path: str) -> bool:
    """A profile argument naming a file (``.toml`` or a path separator), not a bundled name."""
    return name_or_path.endswith(".toml") or "/" in name_or_path or "\\" in name_or_path


def profile_path(name_or_path: str, where: str = "--profile", relative_to: Path | None = None) -> Path:
    """The TOML file of a bundled profile name or a path (relative to ``relative_to``, else to
    the working directory); a missing file or an unknown name is a :class:`ConfigError` naming
    ``where`` (with the nearest bundled names for a misspelt one)."""
    if not isinstance(name_or_path, str) or not name_or_path.strip():
        raise ConfigError(f"{where}: an empty profile name; choose one of {available_profiles()} "
                          "or give the path of a .toml file")
    if _is_path(name_or_path):
        path = Path(name_or_path).expanduser()
        if relative_to is not None and not path.is_absolute():
            path = relative_to / path
        if path.is_dir():
            raise ConfigError(f"{where} {name_or_path}: is a directory, not a .toml file")
        if not path.exists() and not path.is_symlink():
            raise ConfigError(f"{where} {name_or_path}: no such file")
        # anything else that exists (a FIFO, a device, a dangling link) is refused by _read_toml
        if path.suffix != ".toml":
            raise ConfigError(f"{where} {name_or_path}: not a profile (a profile file ends in .toml)")
        return path
    path = PROFILES_DIR / f"{name_or_path}.toml"
    if not is_safe_name(name_or_path) or not path.is_file():
        from navbench.names import did_you_mean

        raise ConfigError(f"{where}: unknown profile {name_or_path!r}{did_you_mean(name_or_path, available_profiles())}; "
                          f"choose one of {available_profiles()} or give the path of a .toml file")
    return path


def _merge(base: dict[str, Any], top: dict[str, Any]) -> dict[str, Any]:
    """``top`` over ``base``: tables merged key by key (recursively), anything else replaced."""
    out = dict(base)
    for k, v in top.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def profile_document(path: Path, _chain: tuple[Path, ...] = ()) -> dict[str, Any]:
    """The TOML document of the profile at ``path`` with its ``extends`` resolved: the parent's
    document (a bundled name, or a path relative to the extending file) under this file's keys,
    tables merged key by key; ``name`` is the file's own (default: the file's stem, never the
    parent's). A cycle is a :class:`ConfigError` naming the chain."""
    chain = (*_chain, path.resolve())
    doc = _read_toml(path)
    parent = doc.pop("extends", None)
    if parent is not None:
        if not isinstance(parent, str) or not parent:
            raise ConfigError(f"{path}: extends: expected a bundled profile name or a .toml path, got {parent!r}")
        ppath = profile_path(parent, f"{path}: extends", relative_to=path.parent)
        if ppath.resolve() in chain:
            names = " -> ".join(p.name for p in (*chain, ppath.resolve()))
            raise ConfigError(f"{path}: extends makes a cycle: {names}")
        base = profile_document(ppath, chain)
        base.pop("name", None)
        doc = _merge(base, doc)
    doc.setdefault("name", path.stem)
    return doc


def load_profile(name_or_path: str | None = None) -> Profile:
    """Load a bundled profile by name, or a TOML file by path (default: ``quick``); ``extends``
    is resolved (:func:`profile_document`)."""
    path = profile_path(DEFAULT_PROFILE if name_or_path is None else name_or_path)
    return profile_from_dict(profile_document(path), str(path))


def override(profile: Profile, **changes: Any) -> Profile:
    """A copy of ``profile`` with the non-``None`` ``changes`` applied (CLI options); each
    changed value is checked and a bad one is reported under its option's name."""
    changes = {k: v for k, v in changes.items() if v is not None}
    unknown = set(changes) - {f.name for f in dataclasses.fields(Profile)}
    if unknown:
        raise ConfigError(f"unknown profile field(s): {sorted(unknown)}")
    if changes.get("benchmark_version", profile.benchmark_version) != profile.benchmark_version:
        raise ConfigError("override: a profile's benchmark version changes with its settings; "
                          "use navbench.pipeline.versioning.with_version")
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
    """``(name, parsed TOML)`` of every readable bundled profile with its ``extends`` resolved
    (:func:`profile_document`), parsed once per process."""
    docs = []
    for name in available_profiles():
        try:
            docs.append((name, profile_document(PROFILES_DIR / f"{name}.toml")))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError, ConfigError):
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
        elif fname == "benchmark_version":  # a file without the key: the current version
            out[name] = benchmark.BENCHMARK_VERSION
        else:
            out[name] = default.default_factory() if default.default is dataclasses.MISSING else default.default
    return out
