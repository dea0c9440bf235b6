"""HouseExpo import: the fixture outline becomes a valid level; malformed documents name the field."""

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from navbench.errors import LevelError
from navbench.level import _is_convex
from navbench.levelio import dumps_level
from navbench.levelgen import (HOUSEEXPO_MARGIN, _inside_polygon, _poly_area, exterior_fill,
                               level_from_houseexpo, level_stats, validate_level)

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "houseexpo_small.json"


@pytest.fixture(scope="module")
def doc():
    return json.loads(FIXTURE.read_text())


@pytest.fixture(scope="module")
def level(doc):
    return level_from_houseexpo(doc, "hx", 4, size=11.4, obstacles=6)


def test_fixture_imports_and_validates(doc, level):
    validate_level(level)
    assert len(level.walls) == len(doc["verts"])  # one wall per outline edge
    ext = level.meta["exterior_obstacles"]
    assert len(level.obstacles) - len(ext) == 6
    assert level_stats(level)["obstacles"] == 6
    assert level.meta["houseexpo_id"] == doc["id"]
    # translated to the origin, scaled to fit, aspect kept (the fixture's bbox is square)
    assert max(level.width, level.depth) == pytest.approx(11.4)
    assert level.width == pytest.approx(level.depth)
    scale = level.meta["scale"]
    assert scale == pytest.approx((11.4 - 2 * HOUSEEXPO_MARGIN) / 10.0)
    a = level.walls[0].a  # first outline vertex (2, 1) moved back by half a thickness along x
    assert a[1] == pytest.approx((1.0 - 1.0) * scale + HOUSEEXPO_MARGIN)


def test_import_is_deterministic(doc, level):
    again = level_from_houseexpo(copy.deepcopy(doc), "hx", 4, size=11.4, obstacles=6)
    assert dumps_level(again) == dumps_level(level)


def test_exterior_fill_covers_exactly_the_outside():
    outline = np.array([[1.0, 1.0], [6.0, 1.0], [6.0, 3.0], [8.0, 5.0], [8.0, 8.0], [3.0, 8.0],
                        [3.0, 5.0], [1.0, 5.0]])
    pieces = exterior_fill(outline, 9.0, 9.0)
    for p in pieces:
        assert _is_convex(np.asarray(p))
        assert _poly_area(np.asarray(p)) > 0  # counter-clockwise
    total = sum(_poly_area(np.asarray(p)) for p in pieces)
    assert total == pytest.approx(81.0 - abs(_poly_area(outline)), abs=1e-6)
    g = (np.arange(90) + 0.5) / 10.0
    X, Y = np.meshgrid(g, g, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], 1)
    inside = _inside_polygon(pts, outline)
    in_fill = np.zeros(len(pts), bool)
    for p in pieces:
        in_fill |= _inside_polygon(pts, np.asarray(p))
    assert np.array_equal(in_fill, ~inside)


def _mutate(doc, fn):
    d = copy.deepcopy(doc)
    fn(d)
    return d


@pytest.mark.parametrize("mutation, field", [
    (lambda d: d.pop("verts"), "verts"),
    (lambda d: d.update(verts="abc"), "verts"),
    (lambda d: d["verts"].__setitem__(3, [1.0, "x"]), "verts[3]"),
    (lambda d: d["verts"].__setitem__(3, [1.0]), "verts[3]"),
    (lambda d: d.pop("bbox"), "bbox"),
    (lambda d: d["bbox"].pop("min"), "bbox.min"),
    (lambda d: d["bbox"].update(max=[5.0, 5.0]), "bbox"),
    (lambda d: d.update(verts=[[2, 2], [6, 6], [6, 2], [2, 6]]), "verts"),  # bow tie
    (lambda d: d.update(verts=[[1, 1], [2, 2], [3, 3]]), "verts"),  # no area
])
def test_malformed_houseexpo_names_the_field(doc, mutation, field):
    with pytest.raises(LevelError) as e:
        level_from_houseexpo(_mutate(doc, mutation), "hx", 0)
    assert f"{field}:" in str(e.value)
    assert "\n" not in str(e.value)


def test_non_object_document_is_rejected():
    with pytest.raises(LevelError, match="document"):
        level_from_houseexpo([1, 2, 3], "hx", 0)
