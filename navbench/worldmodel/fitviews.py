"""Fitting a map to any views, with or without a level: the train / held-out protocol of
``navbench fit-map --views`` (views that navbench did not collect, e.g. a TUM RGB-D import).

The map's box is the views' own (:attr:`Views.box`: the level's box for collected views, the
bounds of the camera centres and back-projected depth points for imported ones), so no level is
needed. Quality is measured on held-out views: the given ``heldout`` views, else a
deterministic split of ``views`` (:func:`navbench.worldmodel.views.heldout_split`: every
``heldout_every``-th view held out, the rest fitted). The slice scores against the true
level appear only when a ``level`` is given.
"""

from __future__ import annotations

from typing import Callable

from navbench.worldmodel.evaluate import evaluate_map
from navbench.worldmodel.fit import FitConfig, fit_map
from navbench.worldmodel.fitconfig import require_depth_within
from navbench.worldmodel.grid import check_fitted_finite
from navbench.worldmodel.views import Views, heldout_split

#: The default split: every 10th view held out (10 % of a sequence; 30 of 300 frames).
HELDOUT_EVERY = 10


def fit_views(views: Views, config: FitConfig, heldout: Views | None = None,
              heldout_every: int = HELDOUT_EVERY, level=None,
              progress: Callable[[int, int, float], None] | None = None):
    """Fit ``M_occ``, ``M_col`` (eq. 3, :func:`~navbench.worldmodel.fit.fit_map`) to ``views``
    (all of them when ``heldout`` is given, else the training part of the split) and evaluate
    the map (:func:`~navbench.worldmodel.evaluate.evaluate_map`) on the held-out views.

    Returns ``(map, metrics)``: the fit's metrics, the held-out quality (``depth_mae_m``,
    ``rgb_l1``, ``coverage``, ``heldout_views``; ``slice_precision`` / ``slice_recall`` only
    with ``level``), ``train_views`` and ``split`` (``"every N"`` or ``"given"``).
    """
    if heldout is None:
        train_idx, held_idx = heldout_split(len(views), heldout_every)
        train, held = views.subset(train_idx), views.subset(held_idx)
        split = f"every {int(heldout_every)}"
    else:
        train, held, split = views, heldout, "given"
    require_depth_within(held, config.max_range, "the held-out views")  # else a score of nothing
    vmap, metrics = fit_map(train, config, progress=progress)
    check_fitted_finite(vmap, metrics, config)
    out = {**dict(metrics), **evaluate_map(vmap, level, held)}
    out.update(train_views=len(train), split=split)
    return vmap, out
