"""Level files (navbench.level): load_level names the bad field; save/load round trip."""

import json

import pytest

from navbench.errors import LevelError
from navbench.levelio import dumps_level, level_to_dict, load_level, save_level
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


@pytest.mark.parametrize("mutation, field", [
    (lambda d: d["walls"][0].update(b=[60.0, 0.0]), "walls[0].b: point"),
    (lambda d: d["walls"][0].update(a=[1e300, 0.0]), "walls[0].a: point"),
    (lambda d: d["walls"][0].update(a=[-0.01, 0.0]), "walls[0].a: point"),
    (lambda d: d.update(obstacles=[{"polygon": [[1, 1], [9, 1], [1, 2]], "height": 0.3,
                                    "texture": 0}]), "obstacles[0].polygon[1]"),
    (lambda d: d.update(width=1e7), "width: expected a number <= 50"),
    (lambda d: d.update(depth=10 ** 400), "depth: expected a finite number"),
    (lambda d: d.update(height=1e6), "height"),
    (lambda d: d["walls"][0].update(thickness=30.0), "walls[0].thickness"),
    (lambda d: d.update(name="../../x"), "name: '../../x' is not a safe name"),
    (lambda d: d.update(name="/tmp/x"), "name: '/tmp/x' is not a safe name"),
])
def test_level_out_of_bounds_or_misnamed(tmp_path, doc, mutation, field):
    d = _broken(doc, mutation)
    with pytest.raises(LevelError) as e:
        load_level(_write(tmp_path, d))
    assert str(e.value).startswith(f"{tmp_path / 'lv.json'}: ")
    assert field in str(e.value)


def test_disconnected_level_is_refused_on_load(tmp_path, doc):
    """A wall across the maze's free space (full height, box to box) splits it in two."""
    d = _broken(doc, lambda d: d["walls"].append(
        {"a": [2.45, 0.0], "b": [2.45, d["depth"]], "thickness": 0.1, "texture": 0}))
    d["name"] = "lv"
    p = _write(tmp_path, d)
    with pytest.raises(LevelError, match="connected components"):
        load_level(p)
    assert len(load_level(p, validate=False).walls) == len(doc["walls"]) + 1


def test_committed_levels_load_unchanged():
    """Every committed level passes the load checks; reading it changes nothing."""
    import hashlib
    from pathlib import Path

    root = Path(__file__).resolve().parents[2] / "levels"
    for p in sorted(root.glob("*.json")):
        before = hashlib.sha256(p.read_bytes()).hexdigest()
        lv = load_level(p)
        assert lv.name == p.stem and dumps_level(lv) == p.read_text()
        assert hashlib.sha256(p.read_bytes()).hexdigest() == before


def test_resolve_level_refuses_unsafe_names(tmp_path):
    from navbench.levelio import resolve_level

    with pytest.raises(LevelError, match="not a safe name"):
        resolve_level("../x", tmp_path)


def test_a_level_loaded_by_file_must_be_named_after_it(tmp_path, doc):
    from navbench.levelio import resolve_level

    d = _broken(doc, lambda d: d.update(name="other"))
    p = _write(tmp_path, d)
    for load in (lambda: resolve_level(str(p)), lambda: load_level(p, name="lv")):
        with pytest.raises(LevelError, match=r"lv.json: name: the level calls itself 'other' but is "
                                             r"loaded as 'lv'"):
            load()
    assert load_level(p).name == "other"  # a cached level.json is loaded without a name
