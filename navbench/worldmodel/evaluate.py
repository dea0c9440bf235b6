"""Map quality on held-out views: depth and colour errors of the rendered images, coverage, and
the occupancy slice against the true level."""

from __future__ import annotations

import numpy as np

from navbench.worldmodel.views import Views


def evaluate_map(vmap, level, heldout: Views, step: float | None = None) -> dict:
    """Render ``heldout`` views from the world model ``vmap`` and compare; slice scores when
    ``level`` is given. The renderer is ``vmap.renderer`` with ``meta['max_range']`` (20 m).

    ``depth_mae_m``: mean |rendered - observed| z-depth (m) over pixels valid in both;
    ``rgb_l1``: mean absolute colour error per channel (in [0, 1]) over the same pixels;
    ``coverage``: fraction of observed-valid pixels the map renders a crossing for;
    ``slice_precision`` / ``slice_recall``: the band occupancy slice vs the level's raster with
    a one-cell tolerance (:func:`navbench.worldmodel.grid.slice_scores`).
    """
    fr = vmap.renderer(heldout.intrinsics, heldout.camera_height,
                       max_range=float(vmap.meta.get("max_range", 20.0)), step=step)
    abs_d, abs_c, n_both, n_obs = 0.0, 0.0, 0, 0
    for k in range(len(heldout)):
        frame = fr.render(heldout.poses[k])
        obs_ok = np.asarray(heldout.valid[k])
        both = obs_ok & frame.valid
        dep = np.asarray(heldout.depth[k], np.float64)
        abs_d += float(np.abs(frame.depth[both] - dep[both]).sum())
        rgb = np.asarray(heldout.rgb[k], np.float32) / 255.0
        abs_c += float(np.abs(frame.rgb[both] - rgb[both]).sum())
        n_both += int(both.sum())
        n_obs += int(obs_ok.sum())
    out = {"depth_mae_m": abs_d / max(1, n_both), "rgb_l1": abs_c / max(1, 3 * n_both),
           "coverage": n_both / max(1, n_obs), "heldout_views": len(heldout)}
    if level is not None:
        from navbench.worldmodel.grid import slice_scores

        out["slice_precision"], out["slice_recall"] = slice_scores(vmap, level)
    return out
