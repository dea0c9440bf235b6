"""The labels the results side gives the unknown-house runs (``--map online|online-fused``).

The stage (:mod:`navbench.pipeline.stages.online`) runs these episodes; scoring and the report
only need to name them and know their default scoring preset, which live here so the results
side never imports a stage.
"""

from __future__ import annotations

#: ``--map`` values of the unknown-house loop -> the mapping model they select.
ONLINE_MAPS = {"online": "perfect", "online-fused": "fused"}
#: The scoring preset of this map mode when the profile keeps the default ``paper``.
ONLINE_PRESET = "nrns"


def online_label(run_config) -> str:
    """The suffix the ``conditions`` label of a run's episodes gets (``""`` unless its recorded
    profile config says ``map_source`` online): ``", map=online, mapping=perfect, pose=true"``
    (``pose=estimator`` when the run's estimators are not just ``gt``: ``ours`` tracks)."""
    if not isinstance(run_config, dict):
        return ""
    mapping = ONLINE_MAPS.get(str(run_config.get("map_source", "")))
    if mapping is None:
        return ""
    pose = "true" if list(run_config.get("estimators") or ["gt"]) == ["gt"] else "estimator"
    ablation = run_config.get("online_ablation") or "full"
    return (f", map={run_config['map_source']}, mapping={mapping}, pose={pose}"
            + ("" if ablation == "full" else f", ablation={ablation}"))
