"""Scoring presets over stored episodes (issue 15 §4; the rules: :mod:`navbench.nav.presets`).

:func:`apply_preset` turns an episodes frame (:func:`navbench.results.score.select_episodes`)
into the frame a preset scores: ``success`` and ``spl_term`` under the preset (``paper``: the
stored columns, untouched), plus ``soft_spl_term`` (habitat's SoftSPL), ``dist_to_goal_m``
(the preset's final distance), ``goal`` (``point`` where the row says nothing: rows stored
before image goals) and ``difficulty`` (NRNS bands of the exact geodesic start-goal length).
The frame's ``attrs["preset"]`` names the preset; every table built from it carries a
``preset`` column, so no number is shown without the rule it was scored by.

Rows stored before the final distances were recorded (``final_dist_m`` / ``final_geo_m``
NULL) have no ``d_T``: they are no success under ``nrns`` and ``habitat`` and have no SoftSPL
or final distance (:func:`missing_distances` counts them; ``score`` warns).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navbench.nav.presets import DEFAULT_PRESET, difficulty, get_preset, preset_terms

if TYPE_CHECKING:  # pragma: no cover
    import pandas

DIFFICULTY_ORDER = ("easy", "medium", "hard", "other", "all")
GOAL_ORDER = ("point", "image")


def apply_preset(frame: "pandas.DataFrame", preset: str = DEFAULT_PRESET,
                 where: str = "--preset") -> "pandas.DataFrame":
    """A copy of the episodes ``frame`` scored under ``preset`` (see the module docstring)."""
    p = get_preset(preset, where)
    if frame.attrs.get("preset") not in (None, p.name):
        raise ValueError(f"the episodes are already scored under {frame.attrs['preset']!r}")
    f = frame.copy()
    # a frame of other origin may lack columns: unknown values (no stop, no distance) score as
    # failures under a preset that needs them; ``paper`` keeps the frame's own success and SPL
    for col in ("final_dist_m", "final_geo_m", "goal", "end_reason", "steps", "path_length", "optimal_length"):
        if col not in f.columns:
            f[col] = None
    if f.empty:
        for col in ("soft_spl_term", "dist_to_goal_m", "difficulty"):
            f[col] = []
        f.attrs["preset"] = p.name
        return f
    terms = preset_terms(p, end_reason=f["end_reason"].to_numpy(dtype=object),
                         steps=f["steps"].to_numpy(dtype=float),
                         path_length=f["path_length"].to_numpy(dtype=float),
                         optimal_length=f["optimal_length"].to_numpy(dtype=float),
                         final_dist_m=f["final_dist_m"].to_numpy(dtype=float),
                         final_geo_m=f["final_geo_m"].to_numpy(dtype=float))
    if p.name != "paper":  # paper: the stored success and SPL terms, bit for bit
        f["success"] = terms["success"]
        f["spl_term"] = terms["spl_term"]
    f["soft_spl_term"] = terms["soft_spl_term"]
    f["dist_to_goal_m"] = terms["dist_to_goal_m"]
    f["goal"] = f["goal"].where(f["goal"].notna(), "point").astype(str)
    f["difficulty"] = difficulty(f["optimal_length"].to_numpy(dtype=float))
    f.attrs["preset"] = p.name
    return f


#: The substring of the ``conditions`` label (:func:`navbench.results.score.with_conditions`)
#: that marks an unknown-house episode (``--map online|online-fused``).
ONLINE_MARK = "map=online"


def online_rows(frame: "pandas.DataFrame") -> int:
    """Episodes of ``frame`` run by the unknown-house loop (their conditions label says
    ``map=online...``); 0 for a frame without the label."""
    if frame.empty or "conditions" not in frame.columns:
        return 0
    return int(frame["conditions"].astype(str).str.contains(ONLINE_MARK, regex=False).sum())


def default_preset(frame: "pandas.DataFrame") -> tuple[str, str | None]:
    """``(preset, warning)``: the preset ``score`` uses when none is given. ``paper``, except for a
    selection of unknown-house episodes only: ``nrns`` (the loop's agent stops on its own, which
    ``paper`` does not read; :data:`navbench.results.labels.ONLINE_PRESET`). A selection
    that mixes both is scored under ``paper`` with a warning naming the online episodes."""
    from navbench.results.labels import ONLINE_PRESET

    n = online_rows(frame)
    if n and n == len(frame):
        return ONLINE_PRESET, None
    if n:
        return DEFAULT_PRESET, (f"{n} of the {len(frame)} episodes are unknown-house ones (--map online or "
                                f"online-fused), scored here under {DEFAULT_PRESET!r}, which does not read "
                                f"their stop decision; pass --preset {ONLINE_PRESET} for their own rule")
    return DEFAULT_PRESET, None


def missing_distances(frame: "pandas.DataFrame") -> int:
    """Episodes of ``frame`` without a stored final distance (stored before issue 15)."""
    if frame.empty or "final_dist_m" not in frame.columns:
        return int(len(frame))
    return int(frame["final_dist_m"].isna().sum())
