"""The localiser's bank is a cached artifact (issue 14, section 6): a second build is a cache
hit, a tampered bank is rebuilt; the localize-eval stage runs end to end on a tiny level."""

from __future__ import annotations

import numpy as np
import pytest

from navbench.geometry import CAMERA_HEIGHT, HALF_CAMERA
from navbench.localize import LocalizerConfig
from navbench.pipeline.cache import ArtifactStore
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.localize import (LocalizeEvalConfig, load_localize_results, load_localizer,
                                               localize_bank_stage, localize_eval_stage, map_inputs,
                                               summarise_localization)
from navbench.pipeline.stages.track_eval import StudyMap
from tests.localize.worlds import ExactWorld, room

CFG = LocalizerConfig(lattice_step=0.5)


@pytest.fixture
def ctx(tmp_path):
    return StageContext(ArtifactStore(tmp_path / "cache"), None)


def _map(calls: list) -> StudyMap:
    world = ExactWorld(room())

    def load():
        calls.append(1)
        return world

    return StudyMap("exact", world.content_hash(), load)


def test_second_build_is_a_cache_hit_and_a_tampered_bank_is_rebuilt(ctx):
    calls: list = []
    vmap = _map(calls)
    first = localize_bank_stage(ctx, vmap, CAMERA_HEIGHT, CFG)
    assert not first.cached and len(calls) == 1
    assert first.meta["build_s"] > 0 and first.meta["bytes"] > 0
    again = localize_bank_stage(ctx, vmap, CAMERA_HEIGHT, CFG)
    assert again.cached and again.key == first.key and len(calls) == 1
    with np.load(first.path) as z:
        pano = z["pano"].copy()
    data = bytearray(first.path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    first.path.write_bytes(bytes(data))
    rebuilt = localize_bank_stage(ctx, vmap, CAMERA_HEIGHT, CFG)
    assert not rebuilt.cached and rebuilt.key == first.key and len(calls) == 2
    with np.load(rebuilt.path) as z:
        np.testing.assert_array_equal(z["pano"], pano)
    # query-time settings do not change the bank's key; bank settings do
    assert localize_bank_stage(ctx, vmap, CAMERA_HEIGHT, LocalizerConfig(lattice_step=0.5, accept=0.5)).cached
    assert localize_bank_stage(ctx, vmap, CAMERA_HEIGHT, LocalizerConfig(lattice_step=0.4)).key != first.key


def test_true_map_bank_is_keyed_by_its_level():
    a = Ref("make-level", "a" * 64, None)
    b = Ref("make-level", "b" * 64, None)
    true = StudyMap("true", "true")
    assert map_inputs(true, a) != map_inputs(true, b)
    assert map_inputs(StudyMap("x.npz", "c" * 64), a) == {"map": "c" * 64}


def test_localize_eval_stage_end_to_end(ctx, tmp_path):
    from navbench.levelio import save_level

    level = room()
    path = save_level(level, tmp_path / "loc-room.json")
    ref = Ref("make-level", "d" * 64, path, True, "loc-room")
    loc, _ = load_localizer(ctx, _map([]), HALF_CAMERA, CAMERA_HEIGHT, CFG)
    assert len(loc.bank.points) > 10
    cfg = LocalizeEvalConfig(queries=4, seed=1, localizer=CFG)
    out = localize_eval_stage(ctx, ref, _map([]), cfg)
    res = load_localize_results(out.path)
    s = summarise_localization(res)
    assert s["queries"] == 4 and s["recall_50cm"] == 1.0 and s["median_loc_err_m"] < 0.02
    assert localize_eval_stage(ctx, ref, _map([]), cfg).cached


def test_summary_figures_by_hand():
    res = {"true": np.zeros((4, 3)), "est": np.array([[0.1, 0, 0], [0.3, 0, 0.1], [0.6, 0, 0.3], [2.0, 0, 0]]),
           "query_ms": np.array([1.0, 2.0, 3.0, 4.0]), "diff": np.zeros(4),
           "info": {"bank_build_s": 1.5, "bank_bytes": 2e6}}
    s = summarise_localization(res)
    assert (s["recall_25cm"], s["recall_50cm"], s["recall_100cm"]) == (0.25, 0.5, 0.75)
    assert s["recall_50cm_10deg"] == 0.5 and s["heading_10deg"] == 0.75
    assert s["median_loc_err_m"] == pytest.approx(0.45) and s["query_ms_median"] == 2.5
    assert s["bank_mb"] == 2.0
