"""Benchmark versions: the one name for what makes two results comparable.

A benchmark version covers everything that decides an episode's outcome or a tracking error: the
simulator's images and dynamics, the levels and task sets, the world model's fit, the built-in
estimators' defaults and the scoring rules. Results are only comparable within one version, so

* every run and every episode row stores the version it was produced under
  (:mod:`navbench.results.db`; a row stored before versions existed is ``navbench-1``);
* ``score``, ``compare`` and the report never pool versions: they take the newest version of the
  selection and say so, and ``--benchmark-version`` selects another
  (:func:`navbench.results.versions.choose_version`);
* a version other than the first is part of every cache key it affects
  (:func:`key_part`: empty for ``navbench-1``, so the keys of everything stored before versions
  existed are unchanged).

Bit-identity guards a refactor (tests/pipeline/test_golden_rows.py); a change meant to alter
results is a new version here, with a changelog entry (docs/changelog.md) and the paired
acceptance test of its issue. Ground floor: no navbench imports.
"""

from __future__ import annotations

#: Every version, oldest first, with what defines it (the changelog has the details).
VERSIONS: dict[str, str] = {
    "navbench-1": "the pymunk simulator with per-pixel procedural textures, the paper's fit and "
                  "trackers as first reproduced (every result stored before versions existed)",
}
#: The version new runs are produced under.
BENCHMARK_VERSION = "navbench-1"
#: The version of rows stored before the column existed.
LEGACY_VERSION = "navbench-1"
#: The Gymnasium environment id of each version (the id's suffix follows the images).
GYM_IDS: dict[str, str] = {"navbench-1": "navbench/PointNav-v0"}


class UnknownVersion(ValueError):
    """A version name that is not in :data:`VERSIONS`."""


def check_version(name, where: str = "benchmark version") -> str:
    """``name`` if it is a known version, else :class:`UnknownVersion` naming the known ones."""
    if not isinstance(name, str) or name not in VERSIONS:
        raise UnknownVersion(f"{where}: unknown {name!r}; known: {', '.join(VERSIONS)}")
    return name


def version_rank(name: str) -> int:
    """Position of ``name`` among the versions, oldest 0; an unknown name (stored by a newer
    navbench) ranks after every known one, ordered by name."""
    names = list(VERSIONS)
    return names.index(name) if name in names else len(names)


def newest(names) -> str:
    """The newest of ``names`` (a non-empty iterable of version names)."""
    return max(names, key=lambda n: (version_rank(n), n))


def key_part(version: str = BENCHMARK_VERSION) -> dict:
    """What a version adds to the cache keys it affects: nothing for ``navbench-1`` (keys made
    before versions existed stay valid), ``{"benchmark": version}`` for any later one."""
    return {} if version == LEGACY_VERSION else {"benchmark": version}
