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
    """``name`` if it is a known version (a simulator suffix included, :func:`sim_version`),
    else :class:`UnknownVersion` naming the known ones."""
    base, sim = split_version(name) if isinstance(name, str) else (None, None)
    if base not in VERSIONS or sim not in SIMULATORS:
        known = [sim_version(v, s) for v in VERSIONS for s in SIMULATORS]
        raise UnknownVersion(f"{where}: unknown {name!r}; known: {', '.join(known)}")
    return name


def version_rank(name: str) -> int:
    """Position of ``name``'s version among the versions, oldest 0 (a simulator suffix ranks
    with its version); an unknown name (stored by a newer navbench) ranks after every known
    one, ordered by name."""
    names = list(VERSIONS)
    base = split_version(name)[0]
    return names.index(base) if base in names else len(names)


def newest(names) -> str:
    """The newest of ``names`` (a non-empty iterable of version names); of one version on two
    simulators, the reference simulator's (another is chosen by name)."""
    return max(names, key=lambda n: (version_rank(n), split_version(n)[1] == REFERENCE_SIM, n))


def key_part(version: str = BENCHMARK_VERSION) -> dict:
    """What a version adds to the cache keys it affects: nothing for ``navbench-1`` (keys made
    before versions existed stay valid), ``{"benchmark": version}`` for any later one."""
    return {} if version == LEGACY_VERSION else {"benchmark": version}


# ------------------------------------------------------------------ simulators (issue 37)

#: The simulators a version's episodes can run on; the first is the reference.
SIMULATORS = ("pymunk", "vizdoom")
#: The reference simulator: its version names (and cache keys) carry no simulator.
REFERENCE_SIM = "pymunk"


def sim_version(version: str, sim: str) -> str:
    """The benchmark version of results produced by ``sim``: ``version`` itself on the reference
    simulator, ``"<version>+<sim>"`` on another (``navbench-1+vizdoom``): results of two
    simulators are never pooled (they are two versions to ``score``, ``compare`` and the report)."""
    return version if sim == REFERENCE_SIM else f"{version}+{sim}"


def split_version(name: str) -> tuple[str, str]:
    """``(version, simulator)`` of a version name (:func:`sim_version`'s inverse)."""
    base, plus, sim = name.partition("+")
    return (base, sim) if plus else (name, REFERENCE_SIM)


def sim_key_part(sim: str) -> dict:
    """What a simulator adds to the cache keys it affects (views, episodes, tracking studies):
    nothing for the reference simulator (every key made before the choice existed is
    unchanged), ``{"sim": sim}`` for another."""
    return {} if sim == REFERENCE_SIM else {"sim": sim}
