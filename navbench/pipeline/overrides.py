"""``--set KEY=VALUE``: one profile field changed from the command line (or ``run_profile(sets=)``).

``KEY`` is the field's place in the profile's TOML file, dotted (``fit.steps``, ``tasks.count``,
``navigation.estimators``, ``levels``, ``navigation.episode.max_steps``,
``navigation.options.ours.optimizer``, ``conditions.pose_quantisation``). ``VALUE`` is read by the
field's type: a list field takes comma-separated names (``levels=house-1,house-2``) or a TOML
array; a number or boolean is read as TOML (``fit.lr=0.05``, ``tasks.count=3``); a string field
takes the text as typed. The changed value is checked exactly as a profile field is (type, range,
NaN and infinity refused), and the profile as a whole again (grid size, seeds), before any stage
runs. The result is an ordinary :class:`~navbench.pipeline.profiles.Profile`: the run's resolved
config stores it, and every cache key that reads the field changes with it (and only those).

``benchmark_version=NAME`` is applied first, whatever its place among the items: the profile
takes that version's settings (:func:`navbench.pipeline.versioning.with_version`), and every
other item is set over them, so a value typed on the command line always wins.
"""

from __future__ import annotations

import dataclasses
import tomllib
from typing import Any, Iterable

from navbench.errors import ConfigError

#: Profile fields holding a list of names (a --set value is split on commas).
_LIST_FIELDS = ("levels", "estimators", "noise", "tasks_difficulty")
#: Profile fields holding a table whose entries --set reaches by a longer dotted key.
_TABLE_KEYS = {"fit": "fit", "navigation.episode": "episode", "navigation.options": "estimator_options",
               "navigation.goal_localizer": "goal_localizer"}


def _field_keys() -> dict[str, str]:
    """``dotted TOML key -> Profile field`` of every plain field."""
    from navbench.pipeline.profiles import _SECTIONS

    out = {}
    for section, keys in _SECTIONS.items():
        for k, fname in keys.items():
            if fname in ("episode", "estimator_options", "goal_localizer"):
                continue
            out[f"{section}.{k}" if section else k] = fname
    return out


def known_keys() -> list[str]:
    """The keys ``--set`` accepts, as the one-line error lists them."""
    return [*_field_keys(), "fit.<FitConfig field>", "navigation.episode.<EpisodeConfig field>",
            "navigation.options.<estimator>.<option>", "navigation.goal_localizer.<field>",
            "conditions.<name>"]


def _toml_value(text: str, label: str = "--set") -> Any:
    """``text`` read as a TOML value (number, boolean, array, quoted string), else the text.
    Refused in one line naming ``label`` (the limits of ``-o`` values, :mod:`navbench.safeio`):
    a value over ``MAX_OPTION_CHARS`` characters, nested deeper than ``MAX_DEPTH`` (the parser
    would exhaust the stack), an integer too long to read."""
    from navbench.safeio import MAX_DEPTH, MAX_OPTION_CHARS, check_depth

    if len(text) > MAX_OPTION_CHARS:
        raise ConfigError(f"{label}: a value of {len(text)} characters; at most {MAX_OPTION_CHARS}")
    try:
        v = tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:
        raise ConfigError(f"{label}: nested more than {MAX_DEPTH} levels deep") from None
    except ValueError as e:  # an integer longer than Python's digit limit
        raise ConfigError(f"{label}: {str(e).splitlines()[0]}") from None
    check_depth(v, label, ConfigError)
    return v


def _typed(fname: str, text: str, label: str = "--set") -> Any:
    """A --set value for the Profile field ``fname``, read by the field's type."""
    if fname in _LIST_FIELDS:
        if text.strip().startswith("["):
            return _toml_value(text, label)
        return [t.strip() for t in text.split(",") if t.strip()]
    if fname in ("name", "description", "benchmark_version", "camera", "map_source", "goal", "scoring_preset",
                 "online_ablation", "sim"):
        v = _toml_value(text, label)
        return v if isinstance(v, str) else text
    return _toml_value(text, label)


def parse_set(item: str, where: str = "--set") -> tuple[str, str]:
    """``"fit.steps=300"`` -> ``("fit.steps", "300")``."""
    key, sep, value = str(item).partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(f"{where} {item}: expected KEY=VALUE, e.g. fit.steps=300 or tasks.count=3")
    return key, value.strip()


def _nested(table: dict, path: list[str], value: Any) -> dict:
    """A copy of ``table`` with ``value`` at the dotted ``path`` (inner tables copied)."""
    out = dict(table)
    if len(path) == 1:
        out[path[0]] = value
    else:
        inner = out.get(path[0])
        out[path[0]] = _nested(inner if isinstance(inner, dict) else {}, path[1:], value)
    return out


def apply_sets(profile, items: Iterable[str], where: str = "--set"):
    """``profile`` with every ``KEY=VALUE`` of ``items`` applied (later ones win), checked as
    the profile's own fields are; a :class:`ConfigError` names the ``--set`` item."""
    from navbench.pipeline.checks import _Invalid
    from navbench.pipeline.profiles import FIELDS, _validating_as

    items = list(items or ())
    if not items:
        return profile
    plain = _field_keys()
    changes: dict[str, Any] = {}
    conditions: dict[str, str] = {}
    parsed = [parse_set(item, where) for item in items]
    versions = [text for key, text in parsed if key == "benchmark_version"]
    if versions:  # first: the version's settings are the defaults every other item is set over
        from navbench.pipeline.versioning import with_version

        profile = with_version(profile, _typed("benchmark_version", versions[-1]), where)
    for key, text in parsed:
        label = f"{where} {key}"
        if key == "benchmark_version":
            continue
        if key in plain:
            fname, value = plain[key], _typed(plain[key], text, label)
        else:
            section = next((s for s in _TABLE_KEYS if key.startswith(s + ".")), None)
            if key.startswith("conditions.") and key.count(".") == 1:
                conditions[key.split(".", 1)[1]] = text
                continue
            if section is None:
                from navbench.names import did_you_mean

                raise ConfigError(f"{label}: unknown key{did_you_mean(key, plain)}; known: {', '.join(known_keys())}")
            fname = _TABLE_KEYS[section]
            path = key[len(section) + 1:].split(".")
            if fname == "estimator_options" and len(path) != 2:
                raise ConfigError(f"{label}: expected navigation.options.<estimator>.<option>=VALUE")
            value = _nested(changes.get(fname, getattr(profile, fname)), path, _toml_value(text, label))
        try:
            FIELDS[fname][1](value)
        except _Invalid as e:
            shown = text if len(text) <= 200 else f"{text[:60]}...({len(text)} characters)"
            raise ConfigError(f"{label}={shown}: {e}") from None
        changes[fname] = value
    if conditions:
        from navbench.sim.conditions import conditions_to_episode

        # over the profile's own [conditions] (the command line wins, as --condition)
        changes["episode"] = {**changes.get("episode", profile.episode),
                              **conditions_to_episode(conditions, f"{where} conditions")}
    for k in _LIST_FIELDS:
        if k in changes:
            changes[k] = tuple(changes[k])
    with _validating_as(where):
        return dataclasses.replace(profile, **changes)
