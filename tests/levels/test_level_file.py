"""Level files (navbench.level): load_level names the bad field; save/load round trip."""

import json

import pytest

from navbench.errors import LevelError
from navbench.level import dumps_level, level_to_dict, load_level, save_level
from navbench.levelgen import generate_maze


@pytest.fixture(scope="module")
def doc():
    lv = generate_maze("m", 3, size=4.9)
    return level_to_dict(lv)


def _write(tmp_path, doc_or_text):
    p = tmp_path / "lv.json"
    p.write_text(doc_or_text if isinstance(doc_or_text, str) else json.dumps(doc_or_text))
    return p


def test_save_load_round_trip(tmp_path):
    lv = generate_maze("m", 3, size=4.9)
    p = save_level(lv, tmp_path / "levels" / "m.json")
    back = load_level(p)
    assert back == lv and back.meta == lv.meta
    assert p.read_text() == dumps_level(lv)


def test_missing_file(tmp_path):
    with pytest.raises(LevelError, match="no such level file"):
        load_level(tmp_path / "nope.json")


def test_bad_json(tmp_path):
    with pytest.raises(LevelError, match="not valid JSON"):
        load_level(_write(tmp_path, '{"schema_version": 1,'))


def _broken(doc, fn):
    d = json.loads(json.dumps(doc))
    fn(d)
    return d


@pytest.mark.parametrize("mutation, field", [
    (lambda d: d.pop("walls"), "walls: missing field"),
    (lambda d: d.update(schema_version=99), "schema_version: unknown schema version"),
    (lambda d: d["walls"][2].update(thickness=-1), "walls[2].thickness"),
    (lambda d: d["walls"][1].update(texture=999), "walls[1].texture"),
    (lambda d: d.update(floor_texture=-1), "floor_texture"),
    (lambda d: d["textures"][0].update(kind="marble"), "textures[0].kind"),
    (lambda d: d.update(obstacles=[{"polygon": [[1, 1], [2, 1], [1.2, 1.2], [1, 2]], "height": 0.3,
                                    "texture": 0}]), "obstacles[0].polygon"),
    (lambda d: d.update(obstacles=[{"polygon": [[1, 1], [2, 1], [1, 2]], "height": 0.3,
                                    "texture": 77}]), "obstacles[0].texture"),
    (lambda d: d.update(obstacles=[{"polygon": [[1, 1], [2, 1], [1, 2]], "height": 5.0,
                                    "texture": 0}]), "obstacles[0].height"),
    (lambda d: d.update(width="wide"), "width"),
])
def test_malformed_level_names_the_field(tmp_path, doc, mutation, field):
    with pytest.raises(LevelError) as e:
        load_level(_write(tmp_path, _broken(doc, mutation)))
    msg = str(e.value)
    assert field in msg
    assert "\n" not in msg
