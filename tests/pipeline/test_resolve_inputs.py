"""resolve_views and resolve_map (issue 13): one spec string -> the object and its content key,
whether the spec is a file, a TUM directory or a cache key."""

from __future__ import annotations

import numpy as np
import pytest

from navbench.errors import NavbenchError
from navbench.geometry import Intrinsics
from navbench.pipeline.cache import ArtifactStore
from navbench.pipeline.stages import (LevelConfig, StageContext, TrueMapConfig, make_level_stage, resolve_map,
                                      resolve_views, store_views_stage, true_map_stage)
from navbench.levelio import save_level
from navbench.worldmodel.tum import export_views
from navbench.worldmodel.views import collect_views, save_views, views_content_hash
from tests.pipeline.test_stages import tiny_level


@pytest.fixture
def ctx(tmp_path):
    (tmp_path / "levels").mkdir()
    save_level(tiny_level(), tmp_path / "levels" / "tiny.json")
    return StageContext(ArtifactStore(tmp_path / "cache"), levels_dir=tmp_path / "levels")


def test_resolve_views_path_dir_tum_and_key_agree(ctx, tmp_path):
    v = collect_views(tiny_level(), 4, Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0), seed=0)
    h = views_content_hash(v)
    assert resolve_views(str(save_views(v, tmp_path / "v.npz")), ctx)[1] == h
    assert resolve_views(str(save_views(v, tmp_path / "vdir")), ctx)[1] == h
    tum = export_views(v, tmp_path / "tum")
    imported, key = resolve_views(str(tum), ctx)
    ref = store_views_stage(ctx, imported)
    again, key2 = resolve_views(ref.key[:8], ctx)
    assert key2 == key == ref.meta["content"] and len(again) == 4
    np.testing.assert_array_equal(again.rgb, v.rgb)
    for bad in ("nope", "abcdef99"):
        with pytest.raises(NavbenchError, match=bad):
            resolve_views(bad, ctx)


def test_resolve_map_path_and_key_agree(ctx):
    ref = true_map_stage(ctx, make_level_stage(ctx, LevelConfig("tiny")), TrueMapConfig(cell=0.25, nz=6))
    model, key = resolve_map(str(ref.path), ctx)
    model2, key2 = resolve_map(ref.key[:10], ctx)
    assert key == key2 == model.content_hash()
    np.testing.assert_array_equal(model.occ, model2.occ)
    for bad in ("nope.npz", "abcdef99"):
        with pytest.raises(NavbenchError, match=bad.split(".")[0]):
            resolve_map(bad, ctx)
