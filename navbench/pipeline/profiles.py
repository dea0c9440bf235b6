"""Profiles: named TOML bundles of stage settings (``navbench/profiles/<name>.toml``).

A profile fixes everything ``navbench all`` needs: levels, views, fit, tasks and the navigation
grid. CLI options override single fields (:func:`override`). A profile argument is either a
bundled name (``quick``, ``paper``) or a path to a ``.toml`` file of the same layout::

    name = "quick"
    levels = ["house-1"]
    level_seed = 1
    [views]       camera, count, seed, eval_count, eval_seed
    [fit]         steps, seed, and optionally any other FitConfig field
    [tasks]       count, seed
    [navigation]  estimators, noise, seeds, workers (0 = CPU count), map ("fit" or "true"),
                  and optional
                  [navigation.episode] (EpisodeConfig fields) and
                  [navigation.options.<estimator>] (estimator keyword arguments)

Unknown keys are errors (a typo must not silently fall back to a default).
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from navbench.errors import ConfigError

PROFILES_DIR = Path(__file__).resolve().parent.parent / "profiles"
DEFAULT_PROFILE = "quick"
CAMERA_NAMES = ("half", "paper")
NOISE_NAMES = ("none", "low", "mid", "high", "tracking")


@dataclass(frozen=True)
class Profile:
    """The resolved settings of one profile (units in the comments)."""

    name: str
    description: str = ""
    levels: tuple[str, ...] = ("house-1",)
    level_seed: int = 1              # levelgen seed when levels/NAME.json is not committed
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
    map_source: str = "fit"          # "fit": fitted world model; "true": voxelized true geometry
    episode: dict = field(default_factory=dict)    # EpisodeConfig fields
    estimator_options: dict = field(default_factory=dict)  # estimator -> keyword arguments

    def __post_init__(self):
        validate(self)


def validate(p: Profile) -> None:
    """Raise :class:`ConfigError` for out-of-range fields."""
    if not p.levels:
        raise ConfigError(f"profile {p.name}: no levels")
    if p.camera not in CAMERA_NAMES:
        raise ConfigError(f"profile {p.name}: unknown camera {p.camera!r}; choose one of {CAMERA_NAMES}")
    for n in p.noise:
        if n not in NOISE_NAMES:
            raise ConfigError(f"profile {p.name}: unknown noise level {n!r}; choose one of {NOISE_NAMES}")
    for fname in ("views", "eval_views", "fit_steps", "tasks", "seeds"):
        if int(getattr(p, fname)) < 1:
            raise ConfigError(f"profile {p.name}: {fname} must be >= 1, got {getattr(p, fname)}")
    if p.workers < 0:
        raise ConfigError(f"profile {p.name}: workers must be >= 0")
    if p.eval_seed == p.views_seed:
        raise ConfigError(f"profile {p.name}: eval_seed must differ from the views seed "
                          "(the held-out views must not be the training views)")
    if p.map_source not in ("fit", "true"):
        raise ConfigError(f"profile {p.name}: map must be 'fit' or 'true', got {p.map_source!r}")
    if not p.estimators:
        raise ConfigError(f"profile {p.name}: no estimators")


_SECTIONS: dict[str, dict[str, str]] = {
    "": {"name": "name", "description": "description", "levels": "levels", "level_seed": "level_seed"},
    "views": {"camera": "camera", "count": "views", "seed": "views_seed",
              "eval_count": "eval_views", "eval_seed": "eval_seed"},
    "fit": {"steps": "fit_steps", "seed": "fit_seed"},
    "tasks": {"count": "tasks", "seed": "tasks_seed"},
    "navigation": {"estimators": "estimators", "noise": "noise", "seeds": "seeds",
                   "workers": "workers", "map": "map_source", "episode": "episode",
                   "options": "estimator_options"},
}


def profile_from_dict(doc: dict[str, Any], source: str = "<profile>") -> Profile:
    """Build a :class:`Profile` from a parsed TOML document; unknown keys are errors."""
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
                if k not in _SECTIONS[key]:
                    raise ConfigError(f"{source}: unknown key {key}.{k}")
                kw[_SECTIONS[key][k]] = v
        elif key in _SECTIONS[""]:
            kw[_SECTIONS[""][key]] = value
        else:
            raise ConfigError(f"{source}: unknown key {key!r}")
    if "name" not in kw:
        raise ConfigError(f"{source}: missing 'name'")
    for k in ("levels", "estimators", "noise"):
        if k in kw:
            if not isinstance(kw[k], list) or not all(isinstance(x, str) for x in kw[k]):
                raise ConfigError(f"{source}: {k} must be a list of strings")
            kw[k] = tuple(kw[k])
    kw["fit"] = fit_extra
    try:
        return Profile(**kw)
    except TypeError as e:
        raise ConfigError(f"{source}: {e}") from None


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
        if not path.is_file():
            raise ConfigError(f"unknown profile {name_or_path!r}; choose one of "
                              f"{available_profiles()} or give a .toml path")
    try:
        doc = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not valid TOML ({e})") from None
    return profile_from_dict(doc, str(path))


def override(profile: Profile, **changes: Any) -> Profile:
    """A copy of ``profile`` with the non-``None`` ``changes`` applied (CLI options)."""
    changes = {k: v for k, v in changes.items() if v is not None}
    for k in ("levels", "estimators", "noise"):
        if k in changes:
            changes[k] = tuple(changes[k])
    unknown = set(changes) - {f.name for f in dataclasses.fields(Profile)}
    if unknown:
        raise ConfigError(f"unknown profile field(s): {sorted(unknown)}")
    return dataclasses.replace(profile, **changes)
