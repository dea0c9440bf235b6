"""Scoring from the episode record alone (SPEC "Tasks and scoring"; habitat-style, offline).

* success: the final TRUE position is closer to the target than ``2 L``;
* SPL (Anderson et al. 2018, "On Evaluation of Embodied Navigation Agents", eq. 1; paper
  eq. 8): ``SPL = 1/N sum_i s_i * l_i / max(p_i, l_i)`` with ``s_i`` the success, ``l_i`` the
  shortest feasible path length and ``p_i`` the length of the path the agent took;
* RMSE per trajectory of the estimated against the true poses: location (m) and orientation
  (deg, from wrapped angle differences).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navbench.geometry import AGENT_LENGTH, wrap_angle


@dataclass(frozen=True)
class EpisodeScore:
    """Scores of one episode; lengths in metres, ``rot_rmse_deg`` in degrees."""

    success: bool
    path_length: float
    optimal_length: float
    spl_term: float
    loc_rmse_m: float
    rot_rmse_deg: float
    steps: int
    end_reason: str
    collided: bool
    # the final true position's distance to the target (m): Euclidean, and geodesic for the
    # agent's disc (NaN unless a level or its visibility graph was given); the scoring presets'
    # d_T (navbench.nav.presets)
    final_dist_m: float = float("nan")
    final_geo_m: float = float("nan")


def path_length(true_poses) -> float:
    """Length (m) of the polyline through the positions of ``true_poses (T + 1, 3)`` (or ``(T + 1, 2)``)."""
    p = np.asarray(true_poses, dtype=np.float64)
    if len(p) < 2:
        return 0.0
    return float(np.sum(np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1)))


def success(final_xy, target_xy, agent_length: float = AGENT_LENGTH) -> bool:
    """True when the final true position ``(2,)`` is closer than ``2 * agent_length`` to the target."""
    return bool(math.dist(np.asarray(final_xy, float)[:2], np.asarray(target_xy, float)[:2]) < 2 * agent_length)


def spl_term(success: bool, optimal: float, path: float) -> float:
    """One task's SPL term ``s * l / max(p, l)`` (Anderson et al. 2018); ``l`` optimal, ``p`` taken (m)."""
    if not success:
        return 0.0
    return float(optimal / max(path, optimal))


def spl(scores) -> float:
    """Success weighted by path length: the mean of the episodes' ``spl_term`` (nan if none)."""
    terms = [s.spl_term for s in scores]
    return float(np.mean(terms)) if terms else float("nan")


def location_rmse(true_poses, est_poses) -> float:
    """Root mean square of the position errors (m) over a trajectory ``(T, >=2)``."""
    t = np.asarray(true_poses, dtype=np.float64)[:, :2]
    e = np.asarray(est_poses, dtype=np.float64)[:, :2]
    return float(np.sqrt(np.mean(np.sum((t - e) ** 2, axis=1)))) if len(t) else float("nan")


def orientation_rmse(true_poses, est_poses) -> float:
    """Root mean square of the wrapped heading errors, in degrees, over ``(T, 3)`` poses."""
    t = np.asarray(true_poses, dtype=np.float64)[:, 2]
    e = np.asarray(est_poses, dtype=np.float64)[:, 2]
    if not len(t):
        return float("nan")
    d = wrap_angle(e - t)
    return float(np.degrees(np.sqrt(np.mean(d ** 2))))


def rmse(true_poses, est_poses) -> tuple[float, float]:
    """``(location RMSE [m], orientation RMSE [deg])`` of a trajectory ``(T, 3)``."""
    return location_rmse(true_poses, est_poses), orientation_rmse(true_poses, est_poses)


class FinalGeodesic:
    """Geodesic distance (m) from a final position to the target for the agent's disc in the
    TRUE geometry of ``level`` (:func:`navbench.plan.shortest.shortest_path`, its visibility
    graph built once). Where the disc does not fit at the position (a pose that touched a
    solid) the distance of a point (radius 0) is taken; NaN when even that fails."""

    def __init__(self, level):
        self.level = level
        self._graphs: dict[float, object] = {}

    def _graph(self, radius: float):
        from navbench.plan.shortest import graph_for_level

        if radius not in self._graphs:
            self._graphs[radius] = graph_for_level(self.level, radius)
        return self._graphs[radius]

    def __call__(self, xy, target) -> float:
        from navbench.errors import TaskError
        from navbench.geometry import AGENT_RADIUS
        from navbench.plan.shortest import shortest_path

        for radius in (AGENT_RADIUS, 0.0):
            try:
                return float(shortest_path(self._graph(radius), xy, target)[0])
            except TaskError:
                continue
        return float("nan")


def score_episode(record, agent_length: float = AGENT_LENGTH, geodesic=None) -> EpisodeScore:
    """Score an :class:`navbench.nav.episode.EpisodeRecord` (only its recorded arrays are used).

    ``geodesic``: a :class:`FinalGeodesic` of the episode's level (``(xy, target) -> m``) for
    ``final_geo_m``; without it ``final_geo_m`` is NaN."""
    tp = np.asarray(record.true_poses, dtype=np.float64)
    ep = np.asarray(record.est_poses, dtype=np.float64)
    ok = success(tp[-1, :2], record.target, agent_length)
    p = path_length(tp)
    return EpisodeScore(
        success=ok,
        path_length=p,
        optimal_length=float(record.optimal_length),
        spl_term=spl_term(ok, float(record.optimal_length), p),
        loc_rmse_m=location_rmse(tp, ep),
        rot_rmse_deg=orientation_rmse(tp, ep),
        steps=len(tp) - 1,
        end_reason=str(record.end_reason),
        collided=bool(record.collided),
        final_dist_m=float(math.dist(tp[-1, :2], np.asarray(record.target, float)[:2])),
        final_geo_m=(geodesic(tp[-1, :2], np.asarray(record.target, float)[:2])
                     if geodesic is not None else float("nan")),
    )


def relative_pose_error(true_poses, est_poses, delta: int = 1) -> tuple[float, float]:
    """Relative pose error (Sturm et al. 2012, "A Benchmark for the Evaluation of RGB-D SLAM
    Systems", eq. 1-2) of planar trajectories ``(T, 3)`` over ``delta`` frames: with the SE(2)
    errors ``E_i = (Q_i^-1 Q_{i+delta})^-1 (P_i^-1 P_{i+delta})`` (``Q`` true, ``P`` estimated),
    ``(RMSE of |trans(E_i)| [m], RMSE of |angle(E_i)| [deg])`` over ``i = 0 .. T-1-delta``;
    ``(nan, nan)`` for trajectories shorter than ``delta + 1`` poses. Per frame: ``delta = 1``."""
    q = np.asarray(true_poses, dtype=np.float64).reshape(-1, 3)
    p = np.asarray(est_poses, dtype=np.float64).reshape(-1, 3)
    if len(q) != len(p):
        raise ValueError(f"trajectories of different lengths: {len(q)} and {len(p)} poses")
    if delta < 1 or len(q) <= delta:
        return float("nan"), float("nan")

    def rel(a):  # a_i^-1 a_{i+delta}: translation in the frame of a_i, and the angle
        d = a[delta:, :2] - a[:-delta, :2]
        c, s = np.cos(a[:-delta, 2]), np.sin(a[:-delta, 2])
        return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], 1), a[delta:, 2] - a[:-delta, 2]

    tq, aq = rel(q)
    tp, ap = rel(p)
    # E = Rq^T (tp - tq) in translation, ap - aq in angle (SE(2) rotations commute)
    c, s = np.cos(aq), np.sin(aq)
    d = tp - tq
    et = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], 1)
    ea = wrap_angle(ap - aq)
    return (float(np.sqrt(np.mean(np.sum(et ** 2, axis=1)))),
            float(np.degrees(np.sqrt(np.mean(ea ** 2)))))


# --- intervals (issue 16): exact binomial for success rates, level-stratified bootstrap for SPL ---

def clopper_pearson(successes: int, trials: int, level: float = 0.95) -> tuple[float, float]:
    """Exact binomial (Clopper-Pearson 1934) interval of a success rate ``successes / trials``.

    The bounds are the Beta quantiles ``B((1-level)/2; k, n-k+1)`` and ``B((1+level)/2; k+1, n-k)``
    (0 when ``k = 0``, 1 when ``k = n``), computed by :meth:`scipy.stats.binomtest` with
    ``proportion_ci(method="exact")``. No trials: ``(nan, nan)``.
    """
    from scipy import stats

    n, k = int(trials), int(successes)
    if n <= 0:
        return (float("nan"), float("nan"))
    if not 0 <= k <= n:
        raise ValueError(f"successes must lie in [0, {n}], got {k}")
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=level, method="exact")
    return (float(ci.low), float(ci.high))


def stratified_mean(strata) -> float:
    """The pooled mean of the values of all ``strata`` (a list of 1D arrays): the strata's means
    weighted by their sizes (NaNs dropped); nan when no value is left."""
    parts = [np.asarray(s, dtype=float).ravel() for s in strata]
    parts = [p[np.isfinite(p)] for p in parts]
    total = sum(p.size for p in parts)
    return float(sum(p.sum() for p in parts) / total) if total else float("nan")


def stratified_bootstrap_ci(strata, level: float = 0.95, n_resamples: int = 2000, seed: int = 0,
                            method: str = "BCa") -> tuple[float, float]:
    """Bootstrap interval of the pooled mean of ``strata`` (1D arrays, e.g. one per level),
    resampling within each stratum (stratified bootstrap; NaNs dropped, empty strata ignored).

    Each stratum is passed to :func:`scipy.stats.bootstrap` as a separate sample (scipy
    resamples independent samples separately, ``paired=False``), and the statistic recombines
    them with the fixed weights ``n_k / N``: ``sum_k n_k / N * mean(resample_k)``. So every
    resample keeps each level's episode count, and the pooled mean is the statistic's value on
    the data. With one stratum this is scipy's one-sample bootstrap of the mean. ``method``:
    ``"BCa"`` (bias-corrected and accelerated; its jackknife leaves out one value of one stratum
    at a time) or ``"percentile"``; where BCa is undefined (a bootstrap distribution with no
    spread) the percentile interval is returned, and a constant sample gives ``(v, v)``.
    A stratum of one value is constant under resampling; it is passed twice over (the same
    resamples) since scipy needs two values per sample. Seeded: ``numpy.random.default_rng(seed)``.
    """
    import warnings

    from scipy import stats

    parts = [np.asarray(s, dtype=float).ravel() for s in strata]
    parts = [p[np.isfinite(p)] for p in parts]
    parts = [p for p in parts if p.size]
    if not parts:
        return (float("nan"), float("nan"))
    sizes = np.array([p.size for p in parts], dtype=float)
    weights = sizes / sizes.sum()
    allv = np.concatenate(parts)
    if np.all(allv == allv[0]):
        return (float(allv[0]), float(allv[0]))
    data = tuple(np.repeat(p, 2) if p.size == 1 else p for p in parts)

    def pooled(*samples, axis=-1):
        return sum(w * np.mean(s, axis=axis) for w, s in zip(weights, samples))

    def run(m: str):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy's DegenerateDataWarning: handled below
            res = stats.bootstrap(data, pooled, n_resamples=n_resamples, vectorized=True,
                                  paired=False, confidence_level=level, method=m,
                                  rng=np.random.default_rng(seed))
        return float(res.confidence_interval.low), float(res.confidence_interval.high)

    low, high = run(method)
    if not (np.isfinite(low) and np.isfinite(high)) and method.lower() != "percentile":
        low, high = run("percentile")
    return (low, high)
