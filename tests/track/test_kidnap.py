"""Issue 14, sections 3-4: ATE, raw odometry, kidnap injection, the health test and recovery.

Everything runs on the small exact level of :mod:`tests.track.synth` with the exact ray-cast
camera as the "map" (``renderer=``) and a brute-force :class:`GridRelocalizer` rendered from
it: the relocaliser the tests inject in place of ``navbench.localize``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.geometry import HALF_CAMERA, wrap_angle
from navbench.nav.metrics import location_rmse
from navbench.sim.dynamics import Control, predict
from navbench.track.kidnap import body_control, dead_reckoning, kidnap_indices, recovery
from navbench.track.study import TrackingStudyConfig, record_trajectories, run_tracking_study, summarise

from .synth import small_level


@pytest.fixture(scope="module")
def level():
    return small_level()


@pytest.fixture(scope="module")
def cameras(level):
    from navbench.sim.camera import RaycastCamera

    small = HALF_CAMERA.scaled(0.125)
    return RaycastCamera(level, HALF_CAMERA), RaycastCamera(level, small), small


@pytest.fixture(scope="module")
def relocalizer(level, cameras):
    """Brute force over a 0.25 m x 10 deg lattice of the room's free space (exact camera)."""
    from navbench.level import distance_to_solids
    from navbench.track.ours import align
    from navbench.track.relocalize import GridRelocalizer

    full, small_cam, small = cameras
    xs, ys = np.arange(0.375, level.width, 0.25), np.arange(0.375, level.depth, 0.25)
    P = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
    P = P[distance_to_solids(level, P) >= 0.15]
    return GridRelocalizer(lambda p, s: (small_cam if s else full).render(p), HALF_CAMERA, small, P,
                           np.radians(np.arange(-180.0, 180.0, 10.0)), align)


def test_ate_is_the_hand_computed_translation_rmse():
    true = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.5], [2.0, 1.0, 1.0]])
    est = np.array([[0.0, 0.0, 3.0], [1.0, 0.3, 0.0], [2.0, 1.0, -2.0]])  # headings do not count
    assert location_rmse(true, est) == pytest.approx(math.sqrt((0 + 0.09 + 0) / 3), abs=1e-15)
    est[2, :2] += (0.3, 0.4)  # a 0.5 m error
    assert location_rmse(true, est) == pytest.approx(math.sqrt((0.09 + 0.25) / 3), abs=1e-15)


def test_study_ate_and_raw_odometry_are_the_definitions(level):
    cfg = TrackingStudyConfig(trajectories=2, steps=30, estimators=("dynamics", "gt"), noise="mid",
                              odometry="body", seed=4)
    res = run_tracking_study(level, None, cfg)
    tr = res["trajectories"]
    for n in range(2):
        raw = dead_reckoning(tr["start"][n], tr["controls"][n], tr["true_poses"][n])
        # raw odometry by hand: turn, step and the step's offset from the heading, integrated
        pose = tr["start"][n].copy()
        for t, (turn, direction, speed) in enumerate(tr["controls"][n]):
            off = wrap_angle(direction - tr["true_poses"][n, t, 2])
            pose = predict(pose, Control(turn, float(pose[2] + off), speed))
            assert np.allclose(raw[t + 1], pose, atol=1e-12)
        assert tr["raw_odom_ate_m"][n] == pytest.approx(location_rmse(tr["true_poses"][n], raw), abs=1e-15)
        # the dynamics estimator with body-frame odometry is raw odometry; its ATE the loc RMSE
        assert np.allclose(res["estimators"]["dynamics"]["est_poses"][n], raw, atol=1e-12)
        assert res["estimators"]["dynamics"]["loc_rmse_m"][n] == pytest.approx(tr["raw_odom_ate_m"][n])
    assert np.all(tr["raw_odom_ate_m"] > 0)


def test_body_control_keeps_the_offset_from_the_heading():
    u = body_control((0.1, 1.0 + 0.05, 0.12), 1.0, -2.0)
    assert (u.turn, u.speed) == (0.1, 0.12) and u.direction == pytest.approx(-1.95)


def test_kidnap_injection_is_seeded_and_deterministic(level):
    a = record_trajectories(level, 2, 40, seed=5, kidnap_every=10)
    b = record_trajectories(level, 2, 40, seed=5, kidnap_every=10)
    plain = record_trajectories(level, 2, 40, seed=5)
    assert list(kidnap_indices(40, 10)) == [10, 20, 30]
    for ta, tb, tp in zip(a, b, plain):
        assert np.array_equal(ta.true_poses, tb.true_poses) and np.array_equal(ta.kidnapped, tb.kidnapped)
        assert list(np.flatnonzero(ta.kidnapped)) == [10, 20, 30] and tp.kidnapped is None
        assert np.array_equal(ta.true_poses[:10], tp.true_poses[:10])  # identical until the first kidnap
        jumps = np.hypot(*np.diff(ta.true_poses[:, :2], axis=0).T)
        assert np.all(jumps[[9, 19, 29]] > 0) and not ta.collided
        assert np.all(np.delete(jumps, [9, 19, 29]) <= 0.16 + 0.3)  # steps: at most MAX_STEP + noise
    c = record_trajectories(level, 2, 40, seed=6, kidnap_every=10)
    assert not np.array_equal(a[0].true_poses, c[0].true_poses)


def test_recovery_scoring_by_hand():
    true = np.zeros((12, 3))
    est = np.zeros((12, 3))
    kid = np.zeros(12, bool)
    kid[[3, 8]] = True
    est[3:6, 0] = 1.0  # lost for 3 poses after the first kidnap
    est[8:, 2] = math.radians(20)  # never recovers the heading after the second
    alarms = np.zeros(11, bool)
    alarms[2] = True  # raised by the update that produced pose 3
    r = recovery(true, est, kid, alarms)
    assert list(r["index"]) == [3, 8] and list(r["steps"]) == [3, -1]
    assert list(r["detected"]) == [True, False]


def _track(est, cam, poses, controls):
    """Feed ``est`` the exact frames of ``poses`` with ``controls``; estimates and alarms."""
    est.reset(poses[0], cam.render(poses[0]))
    out, alarms = [poses[0]], []
    for t, u in enumerate(controls):
        out.append(est.update(u, cam.render(poses[t + 1])))
        alarms.append(est.last_health["alarm"])
    return np.array(out), np.array(alarms)


def _walk(level, kidnap_at=None, steps=12, seed=0):
    """A short true walk (noise-free) with body-frame controls; optionally kidnapped."""
    tr = record_trajectories(level, 1, steps, noise="none", seed=seed)[0]
    poses = tr.true_poses.copy()
    controls = [Control(*u) for u in tr.controls]
    if kidnap_at is not None:
        poses[kidnap_at:] = [1.4, 1.6, 2.8] if np.hypot(*(poses[kidnap_at, :2] - (1.4, 1.6))) > 1 \
            else [4.2, 2.8, -0.7]
        # the robot is carried off and put down; its odometry keeps reporting zero motion
        controls[kidnap_at - 1:] = [Control(0.0, float(poses[t, 2]), 0.0) for t in range(kidnap_at - 1, steps)]
    return poses, controls


def test_health_fires_on_a_kidnap_and_not_on_normal_tracking(level, cameras):
    from navbench.track.registry import make_estimator

    cam = cameras[0]
    est = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, health=True)
    for seed in range(3):
        poses, controls = _walk(level, steps=15, seed=seed)
        _, alarms = _track(est, cam, poses, controls)
        assert not alarms.any(), seed
    poses, controls = _walk(level, kidnap_at=6)
    _, alarms = _track(est, cam, poses, controls)
    assert not alarms[:5].any() and alarms[5]  # the update producing pose 6 raises it


def test_recovery_with_the_grid_relocaliser_returns_within_tolerance(level, cameras, relocalizer):
    from navbench.track.registry import make_estimator

    cam = cameras[0]
    poses, controls = _walk(level, kidnap_at=6)
    lost = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, health=True)
    est_lost, _ = _track(lost, cam, poses, controls)
    assert np.hypot(*(est_lost[-1, :2] - poses[-1, :2])) > 0.5  # without recovery it stays lost
    ours = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, recover=True,
                          relocalizer=relocalizer)
    est, alarms = _track(ours, cam, poses, controls)
    r = recovery(poses, est, np.isin(np.arange(len(poses)), [6]), alarms)
    assert r["detected"][0] and r["steps"][0] == 0  # relocalised in the kidnap's own step
    err = np.hypot(*(est[6:, :2] - poses[6:, :2]).T)
    rot = np.degrees(np.abs(wrap_angle(est[6:, 2] - poses[6:, 2])))
    assert err.max() < 0.02 and rot.max() < 1.0
    assert not alarms[6:].any()


def test_relocaliser_finds_poses_between_lattice_points(level, cameras, relocalizer):
    cam = cameras[0]
    for pose in ([1.37, 0.81, 2.02], [4.13, 3.16, -2.9], [2.61, 2.47, 0.33]):
        h = relocalizer.localize(cam.render(np.array(pose)))[0]
        assert np.hypot(*(h.pose[:2] - pose[:2])) < 0.02
        assert abs(math.degrees(wrap_angle(h.pose[2] - pose[2]))) < 1.0 and 0.9 < h.confidence <= 1.0


def test_health_off_changes_nothing(level, cameras):
    """With the health test off ``ours`` computes exactly what it did before (no last_health)."""
    from navbench.track.registry import make_estimator

    cam = cameras[0]
    poses, controls = _walk(level, steps=6, seed=1)
    plain = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA)
    health = make_estimator("ours", renderer=cam.render, intrinsics=HALF_CAMERA, health=True)
    plain.reset(poses[0], cam.render(poses[0]))
    a = [plain.update(u, cam.render(p)) for u, p in zip(controls, poses[1:])]
    assert plain.last_health is None
    b, _ = _track(health, cam, poses, controls)
    assert np.array_equal(np.array(a), b[1:])  # the test only reads; the estimates are the same


def test_study_reports_kidnap_figures(level):
    cfg = TrackingStudyConfig(trajectories=1, steps=25, estimators=("dynamics",), kidnap_every=10,
                              odometry="body")
    res = run_tracking_study(level, None, cfg)
    s = summarise(res)["dynamics"]
    assert s["kidnaps"] == 2 and s["recovered_frac"] == 0.0  # dead reckoning never recovers
    assert "detected_frac" not in s  # it has no health test


def test_track_eval_1000_steps_with_a_tiny_count_and_kidnapping(tmp_path, level, monkeypatch):
    """``--steps 1000`` runs (two trajectories of the small level); the recording keeps the
    robot moving without collisions; ATE, raw odometry and kidnap figures reach the JSON and
    the database."""
    import json

    from navbench.cli.commands.track_eval import default_trajectories
    from navbench.levelio import save_level
    from navbench.results.db import ResultsDB
    from tests.bad_input.conftest import nb

    assert [default_trajectories(s) for s in (100, 1000, 10, 7000)] == [30, 3, 30, 1]
    monkeypatch.chdir(tmp_path)
    path = save_level(level, tmp_path / f"{level.name}.json")
    url = f"sqlite:///{tmp_path / 'r.db'}"
    base = ["track-eval", str(path), "--steps", "1000", "--trajectories", "2", "--noise", "mid",
            "--estimators", "dynamics,gt", "--json", "--db", url]
    out = json.loads(nb(*base).out)
    raw = out["meta"]["raw_odometry"]
    assert out["meta"]["odometry"] == "world" and raw["ate_m_median"] > 0.1
    kid = json.loads(nb(*base, "--kidnap-every", "100").out)
    assert kid["meta"]["odometry"] == "body" and kid["meta"]["study_key"] != out["meta"]["study_key"]
    assert kid["gt"]["kidnaps"] == 2 * 9 and kid["gt"]["recovered_frac"] == 1.0
    assert kid["dynamics"]["recovered_frac"] < 0.5
    frame = ResultsDB(url).tracking_frame()
    rows = frame[frame.kidnaps.notna()]
    assert len(rows) == 4 and rows.kidnaps.sum() == 4 * 9
    assert rows[rows.estimator == "gt"].kidnaps_recovered.sum() == 18
    assert frame.raw_odom_ate_m.notna().all()
    trajs = record_trajectories(level, 2, 1000, noise="mid")
    for tr in trajs:
        assert not tr.collided
        moved = np.hypot(*np.diff(tr.true_poses[:, :2], axis=0).T)
        assert np.mean(moved > 0) > 0.3 and np.sum(moved) > 30  # tens of metres, steadily


def test_new_study_fields_leave_existing_keys_alone():
    """At their defaults kidnap_every, odometry, collisions, sim, texture and benchmark_version
    are not hashed: every stored study keeps its key."""
    from navbench.config import to_jsonable
    from navbench.pipeline.stages.track_eval import study_key_config

    old = to_jsonable(TrackingStudyConfig())
    for k in ("kidnap_every", "odometry", "collisions", "sim", "texture", "benchmark_version"):
        old.pop(k)
    assert study_key_config(TrackingStudyConfig()) == old
    kid = study_key_config(TrackingStudyConfig(kidnap_every=7, odometry="body"))
    assert kid == {**old, "kidnap_every": 7, "odometry": "body"}


def test_relocalizers_are_built_once_per_map_and_swappable(monkeypatch):
    """``ours`` builds its relocaliser by name from RELOCALIZERS, lazily and once per map."""
    from navbench.track import relocalize

    built = []

    class Fake:
        def localize(self, frame, k=None):
            return []

    monkeypatch.setitem(relocalize.RELOCALIZERS, "fake", lambda *a: built.append(a) or Fake())

    class Map:
        def content_hash(self):
            return "abc"

    a = relocalize.build_relocalizer("fake", Map(), HALF_CAMERA, 0.5, None)
    b = relocalize.build_relocalizer("fake", Map(), HALF_CAMERA, 0.5, None)
    assert a is b and len(built) == 1
    with pytest.raises(Exception, match="unknown relocalizer"):
        relocalize.build_relocalizer("nope", Map(), HALF_CAMERA, 0.5, None)


def test_recovery_through_the_real_localiser(level, cameras):
    """The default relocaliser, ``navbench.localize.Localizer`` (option ``relocalizer_name``
    ``localize``), built from the world model ``ours`` tracks against, brings a kidnapped
    estimate back within the tolerance (the same walk as the grid relocaliser's test)."""
    from navbench.track.registry import make_estimator
    from tests.localize.worlds import ExactWorld

    cam = cameras[0]
    poses, controls = _walk(level, kidnap_at=6)
    ours = make_estimator("ours", vmap=ExactWorld(level), intrinsics=HALF_CAMERA, recover=True,
                          relocalizer_name="localize")
    est, alarms = _track(ours, cam, poses, controls)
    r = recovery(poses, est, np.isin(np.arange(len(poses)), [6]), alarms)
    from navbench.localize import Localizer

    assert isinstance(ours._relocalizer, Localizer)
    assert r["detected"][0] and r["steps"][0] <= 1
    err = np.hypot(*(est[8:, :2] - poses[8:, :2]).T)
    assert err.max() < 0.05


def test_health_tolerance_has_an_absolute_part(cameras):
    """The health test's depth agreement is ``tol * z + tol_abs``: a reference 1.5 cm off a
    surface about 0.2-0.5 m away fails the relative 5 % alone at the near pixels and passes
    with the 2 cm default; 5 cm off fails either way."""
    from navbench.geometry import Frame, camera_pose
    from navbench.track.eq7 import prepare_reference
    from navbench.track.health import inlier_fraction

    small = HALF_CAMERA.scaled(0.1)
    H, W = small.shape
    depth = np.linspace(0.2, 0.5, H * W).reshape(H, W)  # a near surface, straight ahead
    rgb = np.full((H, W, 3), 0.5)
    frame = Frame(rgb, depth, np.ones((H, W), bool))
    pose = np.array([1.0, 1.0, 0.0])
    idx = np.arange(H * W)
    for off, rel_only, with_abs in ((0.015, None, 1.0), (0.05, 0.0, 0.0)):
        ref = prepare_reference(Frame(rgb, depth + off, np.ones((H, W), bool)), small, camera_pose(pose))
        f_rel = inlier_fraction(ref, frame, pose, idx, band=(-10, 10))
        f_abs = inlier_fraction(ref, frame, pose, idx, band=(-10, 10), tol_abs=0.02)
        # relative: |off| <= 0.05 z holds where z >= off / 0.05 (hand-computed share)
        assert f_rel == pytest.approx(np.mean(depth >= off / 0.05), abs=1e-12)
        assert f_abs == pytest.approx(np.mean(off <= 0.05 * depth + 0.02), abs=1e-12)
        if with_abs is not None:
            assert f_rel < 1.0 and f_abs == with_abs
        if rel_only is not None:
            assert f_rel == rel_only


def test_changed_health_default_is_keyed_and_old_studies_keep_theirs():
    """``health_tol_abs`` changed from 0 to 0.02: a study with the health test on is keyed with
    the value it runs with (the same key as giving it), one with the old value given keeps the
    old meaning under its own key, and a study without the health test keeps its key."""
    from navbench.pipeline.stages.track_eval import study_key_config
    from navbench.track.trackconfig import keyed_options

    assert keyed_options({}) == {} and keyed_options({"optimizer": "adam"}) == {"optimizer": "adam"}
    assert keyed_options({"health": True}) == {"health": True, "health_tol_abs": 0.02}
    assert keyed_options({"recover": True, "health_tol_abs": 0.0}) == {"recover": True, "health_tol_abs": 0.0}
    assert keyed_options({"health": False}) == {"health": False}

    def key(opts):
        return study_key_config(TrackingStudyConfig(estimator_options={"ours": opts}))

    assert key({"health": True}) == key({"health": True, "health_tol_abs": 0.02})
    assert key({"health": True}) != key({"health": True, "health_tol_abs": 0.0})
    assert key({})["estimator_options"] == {"ours": {}}


def test_recovering_studies_are_keyed_by_the_relocalizers_settings():
    """A study that recovers through ``navbench.localize`` is keyed by the LocalizerConfig it
    builds with (a changed localiser default gives a new key); the ``grid`` relocaliser by its
    name; a study without recovery keeps its key."""
    from dataclasses import asdict

    from navbench.localize import LocalizerConfig
    from navbench.pipeline.stages.track_eval import study_key_config
    from navbench.track.relocalize import relocalizer_settings

    assert relocalizer_settings({"health": True}) is None
    assert relocalizer_settings({"recover": True, "relocalizer_name": "grid"}) == {"name": "grid"}
    assert relocalizer_settings({"recover": True}) == {"name": "localize", "config": asdict(LocalizerConfig())}
    key = study_key_config(TrackingStudyConfig(estimator_options={"ours": {"recover": True}}))
    assert key["relocalizers"]["ours"]["config"] == asdict(LocalizerConfig())
    assert "relocalizers" not in study_key_config(TrackingStudyConfig(estimator_options={"ours": {"health": True}}))
