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


def score_episode(record, agent_length: float = AGENT_LENGTH) -> EpisodeScore:
    """Score an :class:`navbench.nav.episode.EpisodeRecord` (only its recorded arrays are used)."""
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
