"""Cache keys of tracking studies hash the estimator options a user gave, not the resolved
:class:`~navbench.track.trackconfig.TrackerConfig`, so a changed default would silently change
the results stored under an old key. This test holds the defaults the stored studies ran with:
a default may change only with its old value in
:data:`~navbench.track.trackconfig.CHANGED_DEFAULTS` (which puts the new value into the keys,
:func:`~navbench.track.trackconfig.keyed_options`), and a new field must be added here, with a
default that leaves the tracker computing what it did (docs/concepts/stages-and-cache.md)."""

from __future__ import annotations

import math
from dataclasses import fields

import pytest

from navbench.track.trackconfig import CHANGED_DEFAULTS, TrackerConfig

#: Every field's default as the stored studies know it (2026-11-26; ``health_tol_abs`` was 0 before
#: that day and is listed in CHANGED_DEFAULTS).
STORED_DEFAULTS = {
    "optimizer": "gauss-newton", "param": "planar", "prior_sigma": (0.01, math.radians(3.0)),
    "off_plane_sigma": (0.005, math.radians(0.5)), "photo_threshold": 1.0, "geo_threshold": 5.0,
    "pixel_scale": 1000.0, "photo_weight": 1.0, "geo_weight": 3.0, "adam_steps": 100,
    "adam_pixels": 1000, "adam_lr": (0.01, 0.01), "adam_betas": (0.9, 0.999), "gn_iters": 10,
    "gn_geo_iters": 5, "gn_pixels": 3000, "gn_tol": (1e-05, 1e-05), "irls_eps": (0.01, 0.01),
    "normal_max_curvature": 0.05, "yaw_search_deg": 24.0, "yaw_search_step_deg": 2.0,
    "yaw_search_pixels": 400, "health": False, "health_tol": 0.05, "health_tol_abs": 0.0,
    "health_photo_tol": 0.3, "health_band": (0.05, 1.1), "health_pixels": 1000,
    "health_min_inliers": 0.5, "recover": False, "relocalizer_name": "localize", "relocalize_top": 3,
    "relocalize_keep": 0, "reference_scale": 1.0,
    # issue 36 (2026-11-27): off by default, navbench-2 turns them on
    "gn_geo_tol": (0.0, 0.0), "yaw_search_gate": 0.0, "yaw_search_turn_deg": 0.0,
    # issue 37 (2026-11-27): off by default (the search's pixels as navbench-1 scores them)
    "yaw_search_spread": False,
}


def test_every_field_is_known_to_the_stored_studies():
    names = {f.name for f in fields(TrackerConfig)}
    assert names - set(STORED_DEFAULTS) == set(), "a new TrackerConfig field: add its default above"
    assert set(STORED_DEFAULTS) - names == set()


@pytest.mark.parametrize("name", sorted(STORED_DEFAULTS))
def test_a_default_changes_only_through_changed_defaults(name):
    now, stored = getattr(TrackerConfig(), name), STORED_DEFAULTS[name]
    if name in CHANGED_DEFAULTS:
        assert CHANGED_DEFAULTS[name] == stored, f"{name}: CHANGED_DEFAULTS must hold its old value"
        assert now != stored
    else:
        assert now == pytest.approx(stored) if isinstance(stored, (float, tuple)) else now == stored, (
            f"TrackerConfig.{name} changed from {stored!r} to {now!r}: list the old value in "
            f"CHANGED_DEFAULTS so that the cache keys change with it")
