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

    A metric over nothing is ``None``, never 0: the depth MAE and RGB L1 when no pixel is both
    observed and rendered (a map that renders nothing within its ``max_range``), the coverage
    when no held-out pixel is observed, a slice score whose denominator is empty.
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
    out = {"depth_mae_m": abs_d / n_both if n_both else None,
           "rgb_l1": abs_c / (3 * n_both) if n_both else None,
           "coverage": n_both / n_obs if n_obs else None, "heldout_views": len(heldout)}
    if level is not None:
        import math

        from navbench.worldmodel.grid import slice_scores

        for k, v in zip(("slice_precision", "slice_recall"), slice_scores(vmap, level)):
            out[k] = v if math.isfinite(v) else None
    return out
