"""Issue 17's fast paths against their references, bit for bit: the heading search scoring all
candidates in one compiled call, the optimisers reusing the reference's inverse pose, the map
renderer's serial kernel on one numba thread, and frames skipped for estimators that never read
them (their episodes are the same with and without a camera)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navbench.geometry import HALF_CAMERA, camera_pose
from navbench.track import eq7, ours
from navbench.track.lie import se3_inverse
from tests.track.synth import small_level


def _yaw_search_reference(ref, frame, pred, cfg, idx, camera_height):
    """The heading search as it was: one accumulate() per candidate (before issue 17)."""
    sub = idx[: cfg.yaw_search_pixels]
    obs = eq7.sample_observation(frame, ref.intr, sub)
    n_half = int(math.floor(cfg.yaw_search_deg / cfg.yaw_search_step_deg + 1e-9))
    best, best_cost = pred.copy(), np.inf
    for k in range(-n_half, n_half + 1):
        cand = pred.copy()
        cand[2] += math.radians(k * cfg.yaw_search_step_deg)
        state = ours._initial_state(cfg.param, cand, camera_height)
        Trel, B, b = eq7.linearization(cfg.param, state, ref.T_wc, camera_height)
        acc = eq7.accumulate(ref, obs, Trel, B, b, cfg)
        kept = acc.counts[0]
        if kept < 0.3 * len(sub):
            continue
        cost = acc.value / kept
        if cost < best_cost:
            best, best_cost = cand, cost
    return best


@pytest.fixture(scope="module")
def scene():
    from navbench.sim.camera import RaycastCamera

    cam = RaycastCamera(small_level(), HALF_CAMERA)
    z0 = np.array([1.2, 1.0, 0.5])
    return cam, z0, eq7.prepare_reference(cam.render(z0), HALF_CAMERA, camera_pose(z0))


@pytest.mark.parametrize("param", ["planar", "se3"])
def test_batched_candidates_equal_one_accumulate_each(scene, param):
    cam, z0, ref = scene
    cfg = ours.make_config({"param": param})
    idx = ours.gn_pixels(*HALF_CAMERA.shape, cfg.gn_pixels, 0)
    obs = eq7.sample_observation(cam.render(z0 + [0.03, -0.02, 0.1]), HALF_CAMERA, idx)
    Ti = se3_inverse(ref.T_wc)
    lins = [eq7.linearization(param, ours._initial_state(param, z0 + [0, 0, d], 0.5), ref.T_wc, 0.5, Ti)
            for d in np.linspace(-0.4, 0.4, 9)]
    values, counts = eq7.accumulate_values(ref, obs, lins, cfg)
    for (Trel, B, b), v, c in zip(lins, values, counts):
        acc = eq7.accumulate(ref, obs, Trel, B, b, cfg)
        assert v == acc.value and list(c) == list(acc.counts)  # bit for bit
    # the reused inverse is the inverse linearization() computes itself
    for d in (-0.3, 0.2):
        state = ours._initial_state(param, z0 + [0.1, 0, d], 0.5)
        for a, b in zip(eq7.linearization(param, state, ref.T_wc, 0.5, Ti),
                        eq7.linearization(param, state, ref.T_wc, 0.5)):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("turn_deg", [-17.0, -3.0, 0.0, 9.0, 21.0])
def test_heading_search_equals_its_reference(scene, turn_deg):
    cam, z0, ref = scene
    cfg = ours.make_config({})
    idx = ours.gn_pixels(*HALF_CAMERA.shape, cfg.gn_pixels, 0)
    frame = cam.render(z0 + np.array([0.02, 0.01, math.radians(turn_deg)]))
    got = ours.yaw_search(ref, frame, z0, cfg, idx, 0.5)
    np.testing.assert_array_equal(got, _yaw_search_reference(ref, frame, z0, cfg, idx, 0.5))


def test_one_numba_thread_renders_serially_and_identically(monkeypatch):
    import numba

    from navbench.geometry import PAPER_CAMERA
    from navbench.worldmodel import fastrender
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    level = small_level()
    vm = voxelize_level(level, grid_for_level(level, shape=(40, 30, 12)))
    par = fastrender.FastRenderer(vm, PAPER_CAMERA, step=0.05)
    monkeypatch.setattr(numba, "get_num_threads", lambda: 1)
    ser = fastrender.FastRenderer(vm, PAPER_CAMERA, step=0.05)
    assert par._kernel is fastrender.render_kernel and ser._kernel is fastrender.render_kernel_serial
    for pose in ([1.2, 1.0, 0.5], [0.7, 1.4, -2.0]):
        a, b = par.render(pose), ser.render(pose)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("estimator", ["dynamics", "gt"])
def test_estimators_without_frames_give_the_same_episode_without_a_camera(estimator):
    """The worker gives the simulator no camera for estimators that never read a frame: their
    episodes (poses, controls, outcome) are those of a run with the camera rendering."""
    from navbench.bench.timers import bench_tasks
    from navbench.nav.episode import run_episode
    from navbench.sim.world import Simulator
    from navbench.track.registry import make_estimator, uses_frames
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    assert not uses_frames(estimator)
    level = small_level()
    vm = voxelize_level(level, grid_for_level(level, shape=(40, 30, 12)))
    occ, xs, ys = vm.occupancy_slice("band")
    task = bench_tasks(level, vm, 1, 3)[0]
    recs = []
    for intr in (HALF_CAMERA, None):
        sim = Simulator(level, noise="mid", seed=5, intrinsics=intr)
        est = make_estimator(estimator, vmap=vm, intrinsics=HALF_CAMERA, seed=5)
        recs.append(run_episode(level, occ, xs, ys, task, est, sim))
    a, b = recs
    assert a.steps > 0 and a.end_reason == b.end_reason and a.collided == b.collided
    for f in ("true_poses", "est_poses", "controls", "plan"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))


@pytest.mark.parametrize("camera, options", [("half", {}), ("paper", {"reference_scale": 0.5}),
                                             ("paper", {"param": "se3"})])
def test_ours_episode_is_the_same_when_the_camera_casts_only_its_pixels(monkeypatch, camera, options):
    """``ours`` declares the pixels it reads (``observed_pixels``) and the simulator casts only
    those: every pose, control and outcome of the episode equals the run with whole frames."""
    from navbench.bench.timers import bench_tasks
    from navbench.geometry import PAPER_CAMERA
    from navbench.nav.episode import run_episode
    from navbench.sim.world import Simulator
    from navbench.track.registry import make_estimator
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    intr = PAPER_CAMERA if camera == "paper" else HALF_CAMERA
    level = small_level()
    vm = voxelize_level(level, grid_for_level(level, shape=(40, 30, 12)))
    occ, xs, ys = vm.occupancy_slice("band")
    task = bench_tasks(level, vm, 1, 3)[0]
    cast = []
    real_render = type(Simulator(level, intrinsics=intr).camera).render

    def spy(self, pose, pixels=None):
        cast.append(pixels is not None)
        return real_render(self, pose, pixels)

    monkeypatch.setattr(type(Simulator(level, intrinsics=intr).camera), "render", spy)
    recs = []
    for sparse in (True, False):
        if not sparse:
            monkeypatch.setattr(ours._PredictionToObservation, "observed_pixels", lambda self: None)
        cast.clear()
        sim = Simulator(level, noise="mid", seed=5, intrinsics=intr)
        est = make_estimator("ours", vmap=vm, intrinsics=intr, seed=5, **options)
        recs.append(run_episode(level, occ, xs, ys, task, est, sim))
        # the first frame is whole, every later one only the declared pixels (or all whole)
        assert cast[0] is False and all(c is sparse for c in cast[1:]) and len(cast) > 5
    a, b = recs
    assert a.steps > 5 and a.end_reason == b.end_reason and a.collided == b.collided
    for f in ("true_poses", "est_poses", "controls", "plan"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))


@pytest.mark.parametrize("options", [{"health": True}, {"recover": True, "relocalizer_name": "grid"},
                                     {"optimizer": "adam"}])
def test_ours_reads_whole_frames_where_it_reads_other_pixels(options):
    """The health test, recovery and Adam read other pixels than the Gauss-Newton sample: no
    declared pixels, whole frames; ``no-map`` (the previous frame is its reference) neither."""
    from navbench.track.base import observed_pixels
    from navbench.track.registry import make_estimator
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    level = small_level()
    vm = voxelize_level(level, grid_for_level(level, shape=(40, 30, 12)))
    assert observed_pixels(make_estimator("ours", vmap=vm, intrinsics=HALF_CAMERA, **options)) is None
    assert observed_pixels(make_estimator("no-map", intrinsics=HALF_CAMERA)) is None
    got = observed_pixels(make_estimator("ours", vmap=vm, intrinsics=HALF_CAMERA, seed=4))
    np.testing.assert_array_equal(got, ours.gn_pixels(*HALF_CAMERA.shape, ours.TrackerConfig().gn_pixels, 4))


@pytest.mark.parametrize("optimizer", ["gauss-newton", "adam"])
def test_lazy_reference_tracks_bit_identically_to_the_full_render(monkeypatch, optimizer):
    """``ours`` renders only the reference pixels eq. 7 reads (LazyFrame): the same estimates,
    bit for bit, as rendering every pixel first, along a noisy walk at the paper camera."""
    from navbench.geometry import PAPER_CAMERA
    from navbench.sim.camera import RaycastCamera
    from navbench.sim.dynamics import Control, apply_dynamics
    from navbench.track.registry import make_estimator
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    level = small_level()
    vm = voxelize_level(level, grid_for_level(level, shape=(60, 45, 16)))
    cam = RaycastCamera(level, PAPER_CAMERA)
    rng = np.random.default_rng(3)
    poses = [np.array([1.2, 1.0, 0.5])]
    controls = []
    for t in range(6 if optimizer == "adam" else 12):
        u = Control(math.radians(8.0 * (-1) ** (t // 4)), poses[-1][2], 0.05 * (t % 3))
        controls.append(u)
        poses.append(apply_dynamics(poses[-1], u, rng.normal(0, 0.05), rng.normal(0, 0.01)))
    frames = [cam.render(p) for p in poses]

    import numba

    monkeypatch.setattr(numba, "get_num_threads", lambda: 1)  # as in a pool worker: serial renders

    def track(lazy: bool):
        monkeypatch.setattr(ours, "LAZY_REFERENCE", lazy)
        est = make_estimator("ours", vmap=vm, intrinsics=PAPER_CAMERA, optimizer=optimizer,
                             **({"adam_steps": 20} if optimizer == "adam" else {}))
        est.reset(poses[0], frames[0])
        out, fractions = [], []
        for u, f in zip(controls, frames[1:]):
            out.append(est.update(u, f))
            if est._ref.lazy is not None:
                fractions.append(est._ref.lazy.done.mean())
        return np.array(out), fractions

    full, none = track(False)
    lazy, fractions = track(True)
    assert not none and len(fractions) == len(controls)
    np.testing.assert_array_equal(lazy, full)
    assert max(fractions) < 1.0  # it rendered less than the whole image


def test_lazy_pixels_equal_the_full_frames_pixels():
    """Every pixel a LazyFrame renders is the full frame's pixel as prepare_reference makes it."""
    from navbench.geometry import PAPER_CAMERA
    from navbench.worldmodel.fastrender import FastRenderer, LazyFrame
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    level = small_level()
    vm = voxelize_level(level, grid_for_level(level, shape=(60, 45, 16)))
    fr = FastRenderer(vm, PAPER_CAMERA)
    pose = np.array([1.2, 1.0, 0.5])
    T = camera_pose(pose, fr.camera_height)
    ref = eq7.prepare_reference(fr.render(pose), PAPER_CAMERA, T)
    lazy = LazyFrame(fr, T)
    idx = ours.gn_pixels(*PAPER_CAMERA.shape, 3000, 0)
    obs = eq7.sample_observation(fr.render(pose + [0.02, 0.0, 0.05]), PAPER_CAMERA, idx)
    lazy.fill(obs.points, obs.ok, np.stack([eq7.linearization("planar", pose + [0.02, 0.0, d], T,
                                                              fr.camera_height)[0] for d in (0.0, 0.05)]))
    m = lazy.done
    assert 0.05 < m.mean() < 0.9
    np.testing.assert_array_equal(lazy.rgb[m], ref.rgb[m])
    np.testing.assert_array_equal(lazy.depth[m], ref.depth[m])
    np.testing.assert_array_equal(lazy.valid[m], ref.valid[m])


def test_lazy_reference_only_where_it_is_faster(monkeypatch):
    """Lazy only for a serial renderer (one numba thread) and an image of the paper's size."""
    import numba

    from navbench.geometry import PAPER_CAMERA
    from navbench.track.registry import make_estimator
    from navbench.worldmodel.grid import grid_for_level, voxelize_level

    level = small_level()
    vm = voxelize_level(level, grid_for_level(level, shape=(30, 24, 10)))
    monkeypatch.setattr(numba, "get_num_threads", lambda: 1)
    assert make_estimator("ours", vmap=vm, intrinsics=PAPER_CAMERA)._lazy_renderer() is not None
    assert make_estimator("ours", vmap=vm, intrinsics=HALF_CAMERA)._lazy_renderer() is None
    monkeypatch.setattr(numba, "get_num_threads", lambda: 2)
    assert make_estimator("ours", vmap=vm, intrinsics=PAPER_CAMERA)._lazy_renderer() is None
