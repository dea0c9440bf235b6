"""The heading search of the prediction-to-observation trackers (:mod:`navbench.track.ours`):
the start pose of the local optimiser, the best of a fan of headings around the prediction,
scored by eq. 7's data term (:func:`navbench.track.eq7.accumulate_values`), and its gates
(issue 36: the search runs only when the turn was large)."""

from __future__ import annotations

import math

import numpy as np

from navbench.geometry import CAMERA_HEIGHT, Frame, camera_pose
from navbench.track.eq7 import (
    Observation,
    Reference,
    TrackerConfig,
    accumulate_values,
    linearization,
    sample_observation,
)
from navbench.track.lie import se3_inverse


def _initial_state(param: str, pred: np.ndarray, camera_height: float):
    return pred.copy() if param == "planar" else camera_pose(pred, camera_height)


def search_positions(count: int, cfg: TrackerConfig) -> np.ndarray:
    """The positions in the tracker's pixel sample (``count`` flat pixel indices, sorted: the
    Gauss-Newton sample of :func:`navbench.track.ours.gn_pixels`) that the heading search scores:
    the first ``yaw_search_pixels`` (the default, navbench-1's: sorted flat indices, so the
    image's top rows, rows 0-16 of 120 and 0-36 of 240 for 400 of 3000 pixels), or with
    ``yaw_search_spread`` as many positions evenly spaced over the sample (the whole image)."""
    n = max(0, min(int(cfg.yaw_search_pixels), int(count)))
    if not cfg.yaw_search_spread or n >= count:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, count - 1, n)).astype(np.int64))


def yaw_search(ref: Reference, frame: Frame, pred: np.ndarray, cfg: TrackerConfig,
               idx: np.ndarray, camera_height: float = CAMERA_HEIGHT,
               obs: Observation | None = None, info: dict | None = None,
               turn: float | None = None) -> np.ndarray:
    """The planar start pose for the local optimiser: the best heading around the prediction.

    Scores ``pred`` with its heading offset by ``k * yaw_search_step_deg`` (``|offset| <=
    yaw_search_deg``) by the mean kept data term of eq. 7 per kept photometric pixel on
    ``yaw_search_pixels`` of ``idx`` (the first ones, or spread over ``idx`` with
    ``yaw_search_spread``: :func:`search_positions`); candidates that keep fewer than 30 % of those pixels are
    skipped. Returns ``pred`` itself when the search is disabled or no candidate qualifies.
    ``obs``: ``sample_observation(frame, ref.observed, idx)`` when the caller has it (its first
    ``yaw_search_pixels`` rows are the same numbers as sampling those pixels again).
    Gates (both off by default: the search runs every step): with
    ``yaw_search_turn_deg > 0`` a predicted turn ``|turn|`` (rad, the prediction's heading minus
    the previous estimate's; None: unknown, counts as large) of at least that opens it, and with
    ``yaw_search_gate > 0`` so does the prediction's own score above the gate (or too few kept
    pixels to score it). When it runs: the same candidates and the same choice as ungated. ``info`` (optional dict) gets
    ``"yaw_score"`` (the prediction's score, NaN if not scored), ``"yaw_searched"`` and, when it
    searched, ``"yaw_offset_deg"`` (the start's heading minus the prediction's).
    """
    pred = np.asarray(pred, dtype=np.float64)
    if cfg.yaw_search_deg <= 0 or cfg.yaw_search_step_deg <= 0:
        return pred.copy()
    if cfg.yaw_search_spread:
        pos = search_positions(len(idx), cfg)
        sub = idx[pos]
        obs = sample_observation(frame, ref.observed, sub) if obs is None else \
            Observation(obs.points[pos], obs.rgb[pos], obs.ok[pos])
    else:  # navbench-1: the first yaw_search_pixels of idx
        sub = idx[: cfg.yaw_search_pixels]
        if obs is None:
            obs = sample_observation(frame, ref.observed, sub)
        else:
            n = len(sub)
            obs = Observation(obs.points[:n], obs.rgb[:n], obs.ok[:n])
    n_half = int(math.floor(cfg.yaw_search_deg / cfg.yaw_search_step_deg + 1e-9))
    best, best_cost = pred.copy(), np.inf
    Ti = se3_inverse(ref.T_wc)
    cands, lins = [], []
    for k in range(-n_half, n_half + 1):
        cand = pred.copy()
        cand[2] += math.radians(k * cfg.yaw_search_step_deg)
        cands.append(cand)
        lins.append(linearization(cfg.param, _initial_state(cfg.param, cand, camera_height),
                                  ref.T_wc, camera_height, Ti))
    turned = None if cfg.yaw_search_turn_deg <= 0 else (
        turn is None or abs(turn) >= math.radians(cfg.yaw_search_turn_deg))
    if turned is False and cfg.yaw_search_gate <= 0:  # the turn rule alone: no turn, no search
        if info is not None:
            info["yaw_searched"] = False
        return pred.copy()
    if cfg.yaw_search_gate > 0 and not turned:  # the prediction's score first (candidate k = 0)
        v0, c0 = accumulate_values(ref, obs, lins[n_half:n_half + 1], cfg)
        kept0 = int(c0[0, 0])
        score = float(v0[0]) / kept0 if kept0 >= 0.3 * len(sub) else math.nan
        if info is not None:
            info["yaw_score"] = score
        if score <= cfg.yaw_search_gate:  # NaN (too few pixels to tell) searches
            if info is not None:
                info["yaw_searched"] = False
            return pred.copy()
        rest = lins[:n_half] + lins[n_half + 1:]
        vr, cr = accumulate_values(ref, obs, rest, cfg)
        values = np.concatenate([vr[:n_half], v0, vr[n_half:]])
        counts = np.concatenate([cr[:n_half], c0, cr[n_half:]])
    else:
        values, counts = accumulate_values(ref, obs, lins, cfg)  # = accumulate() per candidate
    if info is not None:
        info["yaw_searched"] = True
    for cand, value, kept in zip(cands, values.tolist(), counts[:, 0].tolist()):
        if kept < 0.3 * len(sub):
            continue
        cost = value / kept
        if cost < best_cost:
            best, best_cost = cand, cost
    if info is not None:
        info["yaw_offset_deg"] = math.degrees(float(best[2] - pred[2]))
    return best
