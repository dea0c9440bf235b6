"""The options of the prediction-to-observation trackers (:mod:`navbench.track.ours`, eq. 7's
terms in :mod:`navbench.track.eq7`): :class:`TrackerConfig` and :func:`make_config`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from navbench.errors import TrackingError
from navbench.sim.dynamics import NOISE_LEVELS
from navbench.track.base import config_from_options

#: Tracking-study noise ``(sigma_alpha [rad], sigma_s [m])`` = (3 deg, 0.05 L), the default prior.
_TRACKING_NOISE = NOISE_LEVELS["tracking"]

OPTIMIZERS = ("adam", "gauss-newton")
PARAMS = ("planar", "se3")


# ------------------------------------------------------------------------------ configuration

@dataclass(frozen=True)
class TrackerConfig:
    """Options of the prediction-to-observation trackers (all keyword options of the estimators)."""

    optimizer: str = "gauss-newton"  # "adam" (paper) or "gauss-newton"
    param: str = "planar"  # "planar" (x, y, theta) or "se3" (camera pose, projected to planar)
    # dynamics prior: (sigma_xy [m], sigma_theta [rad]) of the Gaussian around the prediction
    prior_sigma: tuple[float, float] = (_TRACKING_NOISE[1], _TRACKING_NOISE[0])
    # se3 only: sigmas of the off-plane components (vertical translation [m], roll/pitch [rad])
    off_plane_sigma: tuple[float, float] = (0.005, math.radians(0.5))
    photo_threshold: float = 1.0  # photometric L1 (sum over RGB, colour units) ignored above
    geo_threshold: float = 5.0  # |point-to-plane| (m) ignored above
    pixel_scale: float = 1000.0  # S: data terms are scaled to a sum over S pixels
    photo_weight: float = 1.0  # weight of the photometric term (eq. 7: 1)
    geo_weight: float = 3.0  # weight of the point-to-plane term per metre (eq. 7 literally: 1)
    # adam (appendix C/E)
    adam_steps: int = 100
    adam_pixels: int = 1000
    adam_lr: tuple[float, float] = (0.01, 0.01)  # (translation [m], rotation [rad]) step sizes
    adam_betas: tuple[float, float] = (0.9, 0.999)
    # gauss-newton (IRLS)
    gn_iters: int = 10
    gn_geo_iters: int = 5  # the first iterations use the point-to-plane term only
    gn_pixels: int = 3000
    gn_tol: tuple[float, float] = (1e-5, 1e-5)  # stop when |step| below (m, rad)
    # the point-to-plane-only iterations end early when |step| is below (m, rad), and the full
    # eq. 7 then runs its own gn_iters - gn_geo_iters at most; (0, 0): never, all gn_geo_iters
    # run (navbench-1). Chosen on tune-house only (docs/notebook/tracking.md, 2026-11-27)
    gn_geo_tol: tuple[float, float] = (0.0, 0.0)
    # (photometric, geometric) IRLS weight floor: residuals below it are weighted quadratically
    irls_eps: tuple[float, float] = (0.01, 0.01)
    # normals: reject where inverse depth is not locally planar (relative second difference)
    normal_max_curvature: float = 0.05
    # heading search before the local optimiser (0 disables it): candidate headings
    # pred_theta + k * yaw_search_step_deg within +-yaw_search_deg are scored by the mean kept
    # data term of eq. 7 on yaw_search_pixels pixels, and the optimiser starts from the best
    # (the prior stays centred on the prediction). A turn in place at mid/high noise is off by up
    # to ~3 sigma = 18-27 deg, far outside the local optimisers' basin.
    yaw_search_deg: float = 24.0
    yaw_search_step_deg: float = 2.0
    yaw_search_pixels: int = 400
    # which of the gn_pixels the search scores (navbench.track.heading.search_positions): False
    # (navbench-1) the first yaw_search_pixels of the sorted sample, i.e. the image's top rows
    # (rows 0-16 of 120: mostly ceiling); True that many spread over the whole sample. On the
    # ViZDoom engine's frames the top rows leave the search choosing headings up to 24 deg off
    # (docs/notebook/vizdoom.md, 2026-11-27); not a default: it changes navbench-1's results
    yaw_search_spread: bool = False
    # gate of the heading search: it runs only when the prediction's own score (the search's:
    # mean kept data term per kept photometric pixel, colour units + geo_weight x metres) is
    # above this, i.e. when the residual says the turn was off; below it the optimiser starts
    # from the prediction. 0: the search runs every step (navbench-1)
    yaw_search_gate: float = 0.0
    # the turn rule of the heading search (deg): the search runs after a predicted turn (the
    # prediction's heading change) of at least this; after a smaller one only when
    # yaw_search_gate > 0 and the residual opens it. 0: off (navbench-1). The controller turns in
    # place by >= 5 deg or steps straight (turn 0), and the dynamics' heading noise acts only on a turn
    yaw_search_turn_deg: float = 0.0
    # tracking health and recovery (issue 14; navbench.track.health, navbench.track.relocalize):
    # health: compute the inlier fraction at each estimate and raise an alarm below
    # health_min_inliers (0.5: calibrated on normal tracking of house-1; "auto": per map, below);
    # recover: on an alarm, relocalise through the relocaliser (health implied). Off by default:
    # with both off the tracker computes exactly what it did before.
    health: bool = False
    health_tol: float = 0.05  # relative z-depth agreement of an inlier ...
    # ... plus this many metres: a fitted map's own depth error (house fits: 1.4-1.8 cm mean
    # absolute), which 5 % of a surface 0.2 m away (a robot held against furniture) is below.
    # 0 until 2026-11-26 (CHANGED_DEFAULTS: studies stored before keep their keys)
    health_tol_abs: float = 0.02
    health_photo_tol: float = 0.3  # colour agreement of an inlier (L1 over RGB)
    health_band: tuple[float, float] = (0.05, 1.1)  # m, heights of the points that count
    health_pixels: int = 1000  # fixed random pixels the health test reads
    # a number, or "auto": the map's own threshold (navbench.track.health.HealthCalibration,
    # calibrated on the map's views; the estimator is then given it as health_threshold=)
    health_min_inliers: float | str = 0.5
    recover: bool = False
    relocalizer_name: str = "localize"  # a name of navbench.track.relocalize.RELOCALIZERS
    relocalize_top: int = 3  # hypotheses verified per relocalisation
    # steps the runner-up hypotheses of a relocalisation (verified, passing the test) are tracked
    # beside the chosen one; then the track with the largest summed inlier fraction is kept
    # (look-alike places diverge as the robot moves). 0: off, the chosen one is final.
    relocalize_keep: int = 0
    # ours only (issue 17): render the map's reference xhat_{t-1} at this fraction of the camera's
    # resolution (Intrinsics.scaled; 0.5: 160 x 120 at the paper camera) and project the observed
    # pixels into it (fewer rays, the same eq. 7); 1.0: the camera's own. Not with health/recover
    reference_scale: float = 1.0

    def __post_init__(self):
        if self.optimizer not in OPTIMIZERS:
            raise TrackingError(f"unknown optimizer {self.optimizer!r}; choose one of {OPTIMIZERS}")
        if self.param not in PARAMS:
            raise TrackingError(f"unknown param {self.param!r}; choose one of {PARAMS}")
        for name in ("adam_steps", "adam_pixels", "gn_iters", "gn_pixels"):
            if int(getattr(self, name)) < 1:
                raise TrackingError(f"option {name} must be >= 1, got {getattr(self, name)!r}")
        if not (min(self.gn_tol) >= 0 and min(self.gn_geo_tol) >= 0 and self.yaw_search_gate >= 0
                and self.yaw_search_turn_deg >= 0):
            raise TrackingError("options gn_tol, gn_geo_tol, yaw_search_gate and yaw_search_turn_deg "
                                "must be >= 0")
        if min(self.prior_sigma) <= 0 or min(self.off_plane_sigma) <= 0:
            raise TrackingError("prior sigmas must be > 0")
        m = self.health_min_inliers
        if not self.health_tol > 0:
            raise TrackingError(f"health_tol must be > 0, got {self.health_tol!r}")
        if not self.health_tol_abs >= 0:
            raise TrackingError(f"health_tol_abs must be >= 0 (m), got {self.health_tol_abs!r}")
        number = isinstance(m, (int, float)) and not isinstance(m, bool)
        if not (m == "auto" or (number and 0 <= m <= 1)):
            raise TrackingError(f"health_min_inliers must be a number within [0, 1] or 'auto', "
                                f"got {m!r}")
        if int(self.health_pixels) < 1 or int(self.relocalize_top) < 1:
            raise TrackingError("health_pixels and relocalize_top must be >= 1")
        k = self.relocalize_keep
        if isinstance(k, bool) or not isinstance(k, int) or k < 0:
            raise TrackingError(f"relocalize_keep must be a step count >= 0, got {k!r}")
        if not 0 < self.reference_scale <= 1:
            raise TrackingError(f"option reference_scale must be within (0, 1], got {self.reference_scale!r}")
        if self.reference_scale != 1 and (self.health or self.recover):
            raise TrackingError("option reference_scale < 1 cannot be combined with health or recover")


def make_config(options: dict[str, Any], base: TrackerConfig | None = None) -> TrackerConfig:
    """Build a :class:`TrackerConfig` from keyword options; unknown names raise TrackingError."""
    return config_from_options(base or TrackerConfig(), options, "tracker")


#: Options whose default changed after results were stored under keys that hash only the options
#: a user gave: option -> its value before the change. The health test alone reads them.
CHANGED_DEFAULTS: dict[str, Any] = {"health_tol_abs": 0.0}


def keyed_options(options: dict[str, Any]) -> dict[str, Any]:
    """An estimator's ``options`` as a cache key holds them: with the health test on (``health``
    or ``recover``), plus the resolved value of each :data:`CHANGED_DEFAULTS` option left at a
    default other than its old one. A result stored before a default changed keeps its key and
    its meaning; one computed after gets the key of the options it ran with (the same as if
    they had been given)."""
    opts = dict(options)
    if not (opts.get("health") is True or opts.get("recover") is True):
        return opts
    cfg = make_config(opts)
    for name, before in CHANGED_DEFAULTS.items():
        if name not in opts and getattr(cfg, name) != before:
            opts[name] = getattr(cfg, name)
    return opts
