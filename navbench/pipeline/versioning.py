"""A profile's benchmark version: the settings it takes from the version, and where it departs.

A benchmark version is a table of settings (:data:`navbench.benchmark.VERSION_SETTINGS`), keyed
by the dotted profile keys ``--set`` takes (``fit.seed``, ``views.camera``,
``navigation.options.ours.<option>``, ``navigation.episode.<field>``). A profile runs under
one version (its ``benchmark_version`` field) and

* takes the version's settings as defaults: a profile file is laid over them
  (:func:`navbench.pipeline.profiles.profile_from_dict`), so whatever the file writes wins, and
  ``--set`` wins over both;
* changes version with :func:`with_version` (``--set benchmark_version=NAME``,
  ``--benchmark-version NAME``): a setting holding the old version's value takes the new
  version's; a setting the profile had changed keeps its value;
* *departs* from its version where a setting some version fixes holds another value than the
  version's (:func:`departures`). A departing run is still a run of its version (its rows carry
  the version, its keys the version's :func:`~navbench.benchmark.key_part`), and its recorded
  config holds every value; the run says so in its log and in ``navbench all``'s summary.

A setting no version names keeps the profile's own value under every version (a profile's sizes
are its business): a version fixes the levers that change results, not a protocol's budget.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from navbench import benchmark
from navbench.config import canonical_json
from navbench.errors import ConfigError
from navbench.pipeline.profiles import _SECTIONS, Profile, _validating_as, check_field

#: A table entry the profile does not set (the underlying config's default applies).
ABSENT: Any = type("Absent", (), {"__repr__": lambda self: "(unset)"})()
#: Profile fields holding a table a longer dotted key reaches into.
_TABLES = ("fit", "episode", "estimator_options", "goal_localizer")


def locate(key: str) -> tuple[str, tuple[str, ...]]:
    """``(Profile field, path inside its table)`` of a dotted setting key; the path is empty for
    a plain field (``fit.seed`` -> ``("fit_seed", ())``, ``fit.lr`` -> ``("fit", ("lr",))``,
    ``navigation.options.ours.x`` -> ``("estimator_options", ("ours", "x"))``)."""
    parts = key.split(".")
    if len(parts) == 1 and key in _SECTIONS[""]:
        return _SECTIONS[""][key], ()
    section = _SECTIONS.get(parts[0]) if parts[0] else None
    if section is not None and len(parts) >= 2 and parts[0] != "conditions":
        fname = section.get(parts[1])
        if fname is not None and fname not in _TABLES and len(parts) == 2:
            return fname, ()
        if fname in _TABLES and len(parts) >= 3:
            return fname, tuple(parts[2:])
        if parts[0] == "fit" and fname is None:
            return "fit", tuple(parts[1:])
    raise ConfigError(f"benchmark version setting {key!r}: not a profile setting")


def _same(a: Any, b: Any) -> bool:
    if a is ABSENT or b is ABSENT:
        return a is b
    return canonical_json(a) == canonical_json(b)


def setting(profile: Profile, key: str) -> Any:
    """The profile's value of the dotted setting ``key`` (:data:`ABSENT` for an unset table entry)."""
    fname, path = locate(key)
    value = getattr(profile, fname)
    for p in path:
        if not isinstance(value, dict) or p not in value:
            return ABSENT
        value = value[p]
    return value


def _set_in(table: dict, path: tuple[str, ...], value: Any) -> dict:
    """A copy of ``table`` with ``value`` at ``path`` (:data:`ABSENT`: the entry removed, and a
    table it leaves empty with it)."""
    out = dict(table)
    head, rest = path[0], path[1:]
    if not rest:
        if value is ABSENT:
            out.pop(head, None)
        else:
            out[head] = value
        return out
    inner = _set_in(out.get(head) if isinstance(out.get(head), dict) else {}, rest, value)
    if inner:
        out[head] = inner
    else:
        out.pop(head, None)
    return out


def version_value(version: str, key: str) -> Any:
    """The value ``version`` gives the setting ``key``: its table's, else the setting's default
    under no version (the Profile field's default; :data:`ABSENT` for a table entry)."""
    table = benchmark.version_settings(version)
    if key in table:
        return table[key]
    fname, path = locate(key)
    if path:
        return ABSENT
    f = next(f for f in dataclasses.fields(Profile) if f.name == fname)
    return f.default_factory() if f.default is dataclasses.MISSING else f.default


def fixed_keys() -> list[str]:
    """Every setting some version fixes (the union of their tables, in version order)."""
    return list(dict.fromkeys(k for v in benchmark.VERSIONS for k in benchmark.VERSION_SETTINGS.get(v, {})))


def with_version(profile: Profile, version: str, where: str = "command line",
                 label: str = "benchmark_version") -> Profile:
    """``profile`` under ``version``: each setting holding the old version's value takes the new
    version's; a setting the profile changed keeps its value. An unknown version is a
    :class:`ConfigError` ``"<where>: <label>: ..."`` naming the known ones."""
    check_field("benchmark_version", version, where, label)
    old = profile.benchmark_version
    if version == old:
        return profile
    changes: dict[str, Any] = {}
    for key in dict.fromkeys([*benchmark.version_settings(old), *benchmark.version_settings(version)]):
        if not _same(setting(profile, key), version_value(old, key)):
            continue  # the profile departed from the old version here: its own value stays
        fname, path = locate(key)
        new = version_value(version, key)
        if path:
            changes[fname] = _set_in(changes.get(fname, getattr(profile, fname)), path, new)
        else:
            changes[fname] = tuple(new) if isinstance(new, list) else new
    for fname, value in changes.items():
        check_field(fname, value, f"benchmark version {version}")
    with _validating_as(where):
        return dataclasses.replace(profile, benchmark_version=version, **changes)


def departures(profile: Profile) -> dict[str, tuple[Any, Any]]:
    """``{setting: (the profile's value, its version's value)}`` for every setting some version
    fixes (:func:`fixed_keys`) where the profile holds another value than its own version's."""
    out = {}
    for key in fixed_keys():
        have, want = setting(profile, key), version_value(profile.benchmark_version, key)
        if not _same(have, want):
            out[key] = (have, want)
    return out


def version_line(profile: Profile) -> str:
    """One line naming the profile's version and its departures (the run log and ``navbench
    all``'s summary): ``benchmark navbench-1``, or for a version of :data:`CANDIDATES`
    ``benchmark navbench-2 (a candidate version, not accepted: docs/changelog.md)``, then any
    departures (``, departing: fit.seed=3 (the version's: 7)``)."""
    return departure_line(profile.benchmark_version, departures(profile))


def departure_line(version: str, gone: dict[str, tuple[Any, Any]]) -> str:
    """``benchmark NAME`` (a version of :data:`navbench.benchmark.CANDIDATES` said to be not
    accepted) and the settings ``gone`` (``{setting: (value, the version's value)}``) that depart
    from it: :func:`version_line`'s text, for a profile's departures or a study's."""
    from navbench.benchmark import CANDIDATES

    note = " (a candidate version, not accepted: docs/changelog.md)" if version in CANDIDATES else ""
    line = f"benchmark {version}{note}"
    if gone:
        line += ", departing: " + "; ".join(f"{k}={v!r} (the version's: {w!r})" for k, (v, w) in gone.items())
    return line


def study_settings(version: str, estimators, where: str = "command line",
                   label: str = "--benchmark-version") -> tuple[str, dict[str, dict]]:
    """What ``version`` gives a tracking study (``navbench track-eval``): the texture mode of its
    frames and, per estimator of ``estimators``, the tracker options it fixes. Read through
    :func:`with_version` from a profile of no settings of its own, so they are the values a
    ``run-navigation`` under ``version`` gives its episodes' camera (``navigation.episode.texture``)
    and its trackers (``navigation.options.<estimator>``): one mapping for both. A profile's own
    navigation options are not the study's (its options are ``--option``), so none is read."""
    from navbench.pipeline.stages.grid import build_episode_config

    neutral = with_version(Profile("track-eval", estimators=tuple(estimators)), version, where, label)
    texture = build_episode_config(neutral.episode).texture
    return texture, {name: dict(neutral.estimator_options[name]) for name in estimators
                     if neutral.estimator_options.get(name)}
