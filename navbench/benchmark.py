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
  existed are unchanged; :func:`affected_stages` says which).

A version is a table of settings (:data:`VERSION_SETTINGS`): the profile settings it fixes, by
the dotted keys ``--set`` takes. A profile naming the version (``benchmark_version = "..."``)
takes them as defaults; the profile or ``--set`` may still set each, and the run then departs from
the version (:mod:`navbench.pipeline.versioning`). ``navbench-1`` is the empty table: the stage
configs' own defaults are its values, so a lever a later version turns on is a config field whose
default is ``navbench-1``'s behaviour.

Bit-identity guards a refactor (tests/pipeline/test_golden_rows.py); a change meant to alter
results is a new version here, with a changelog entry (docs/changelog.md) and the paired
acceptance test of its issue. Ground floor: no navbench imports.
"""

from __future__ import annotations

#: Every version, oldest first, with what defines it (the changelog has the details).
VERSIONS: dict[str, str] = {
    "navbench-1": "the pymunk simulator with per-pixel procedural textures, the paper's fit and "
                  "trackers as first reproduced (every result stored before versions existed; the "
                  "default until 2026-11-27, selectable)",
    "navbench-2": "CANDIDATE, NOT ACCEPTED (its acceptance grid failed, 2026-11-27; "
                  "docs/changelog.md): the camera's textures as texel tables, and ours / no-map "
                  "stopping Gauss-Newton when it has converged with the heading search run on "
                  "turns only",
    "navbench-3": "ACCEPTED 2026-11-27 (its acceptance grid passed; docs/changelog.md): navbench-1 "
                  "with ours' and no-map's heading search scored on pixels spread over the image "
                  "(yaw_search_spread) instead of the image's top rows",
    "navbench-4": "CANDIDATE, NOT ACCEPTED (its acceptance grid failed, 2026-11-27: the paper's claim "
                  "against no-map at mid noise; docs/changelog.md): navbench-3 with navbench-2's "
                  "speed levers but the views' texture: the episode camera's textures as texel "
                  "tables, ours / no-map stopping Gauss-Newton when it has converged and searching "
                  "headings on turns only",
    "navbench-5": "ACCEPTED 2026-11-27 (its acceptance grid passed; docs/changelog.md), THE DEFAULT "
                  "since 2026-11-27: navbench-3 with the episode camera's "
                  "textures as texel tables, an image approximation within half an 8-bit level; the "
                  "views the map is fitted on stay procedural, so every map is navbench-1's",
}
#: The version new runs are produced under: the newest accepted one (navbench-5 since 2026-11-27;
#: navbench-1 before). A profile's ``benchmark_version`` or ``--benchmark-version`` selects another.
BENCHMARK_VERSION = "navbench-5"
#: The version of rows stored before the column existed.
LEGACY_VERSION = "navbench-1"
#: The settings each version fixes: a profile's dotted setting (a key ``--set`` takes, for example
#: ``"fit.seed"``, ``"views.camera"``, ``"navigation.episode.<field>"``,
#: ``"navigation.options.<estimator>.<option>"``) -> its value under the version. Only keys under
#: :data:`SETTING_STAGES` are allowed (``[conditions]`` names: their ``navigation.episode`` field).
#: navbench-2's levers were each measured alone (docs/notebook/speed.md, 2026-11-27; the
#: tracker's tolerances chosen on tune-house only). Its acceptance grid (profile ``acceptance``,
#: 2026-11-27) did not accept it; it stays selectable so that grid can be reproduced.
_CONVERGED = {"gn_geo_tol": [5e-4, 5e-4], "gn_tol": [5e-4, 5e-4], "yaw_search_turn_deg": 1.0}
#: navbench-3's fix, which navbench-4 and navbench-5 build on.
_SPREAD = {f"navigation.options.{est}.yaw_search_spread": True for est in ("ours", "no-map")}
VERSION_SETTINGS: dict[str, dict[str, object]] = {
    "navbench-1": {},
    "navbench-2": {
        "views.texture": "table",
        "navigation.episode.texture": "table",
        **{f"navigation.options.{est}.{k}": v for est in ("ours", "no-map") for k, v in _CONVERGED.items()},
    },
    # the heading search's fix alone (docs/notebook/vizdoom.md: navbench-1's search scores the
    # first 400 of the tracker's row-sorted pixels, the image's top rows); nothing tuned: the
    # same 400 pixels, spread over the image
    "navbench-3": dict(_SPREAD),
    # navbench-3 and navbench-2's levers but the views' texture: navbench-2's grid lost house-2's
    # passages through maps fitted from table-textured views (docs/changelog.md), so the views
    # stay procedural and the maps (and task sets) are navbench-1's; nothing tuned anew
    "navbench-4": {
        "navigation.episode.texture": "table",
        **_SPREAD,
        **{f"navigation.options.{est}.{k}": v for est in ("ours", "no-map") for k, v in _CONVERGED.items()},
    },
    # navbench-4's grid failed on the claim: its tracker levers make no-map as good as ours at
    # mid noise. The image lever alone (a texel table is within 1.43e-3 of the procedural colour)
    # is an approximation of the camera, not a change of a method: navbench-3 with it
    "navbench-5": {"navigation.episode.texture": "table", **_SPREAD},
}
#: Versions that may be chosen but are not accepted (their acceptance grid not run, or failed),
#: so new runs are not produced under them by default (:data:`BENCHMARK_VERSION`).
CANDIDATES: frozenset[str] = frozenset({"navbench-2", "navbench-4"})
#: Where a version's setting reaches the cache keys: the dotted prefix of a setting -> the stages
#: whose own key carries the version (:func:`key_part`). Every stage downstream changes with its
#: inputs' keys, and the navigation grid's cells (episode rows, trajectories, score, report) carry
#: every version but ``navbench-1`` whatever its settings, so "navigation." and "scoring." name
#: no stage of their own.
SETTING_STAGES: dict[str, tuple[str, ...]] = {
    "levels": ("make-level",), "level_seed": ("make-level",),
    "views.": ("collect-views",), "fit.": ("fit-map",), "tasks.": ("sample-tasks",),
    "navigation.goal_localizer.": ("image-goals",), "navigation.": (), "scoring.": (),
}
#: The Gymnasium environment id of each version (the id's suffix follows the images).
#: navbench-3 changes no image (only the built-in trackers), so its environment is navbench-1's.
GYM_IDS: dict[str, str] = {"navbench-1": "navbench/PointNav-v0", "navbench-2": "navbench/PointNav-v1",
                           "navbench-3": "navbench/PointNav-v0", "navbench-4": "navbench/PointNav-v1",
                           "navbench-5": "navbench/PointNav-v1"}


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


def version_settings(version: str) -> dict[str, object]:
    """The settings ``version`` fixes (a copy of its :data:`VERSION_SETTINGS` table)."""
    return dict(VERSION_SETTINGS.get(check_version(version), {}))


def setting_stages(key: str) -> tuple[str, ...]:
    """The stages whose own key a version's setting ``key`` reaches (:data:`SETTING_STAGES`);
    :class:`UnknownVersion` for a key outside them (a version's table is code: a test checks it)."""
    for prefix, stages in SETTING_STAGES.items():
        if key == prefix or (prefix.endswith(".") and key.startswith(prefix) and len(key) > len(prefix)):
            return stages
    raise UnknownVersion(f"benchmark version setting {key!r}: not a setting a version may fix; "
                         f"allowed: {', '.join(SETTING_STAGES)}")


def affected_stages(version: str) -> frozenset[str]:
    """The stages whose key carries ``version`` (:func:`key_part`): those its settings reach
    (:func:`setting_stages`); none for ``navbench-1``. The grid's cells carry every later
    version regardless (:func:`navbench.pipeline.stages.grid.make_cells`)."""
    if version == LEGACY_VERSION:
        return frozenset()
    return frozenset(s for key in version_settings(version) for s in setting_stages(key))


def settings_document(version: str) -> dict:
    """The version's settings as a profile's TOML document (dotted keys nested into tables), the
    base a profile file naming ``version`` is laid over."""
    doc: dict = {}
    for key, value in version_settings(version).items():
        *tables, last = key.split(".")
        node = doc
        for t in tables:
            node = node.setdefault(t, {})
        node[last] = value
    return doc


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
