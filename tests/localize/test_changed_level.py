"""Changed rooms (RNR-Map C.3): seeded, deterministic, valid levels derived from a base."""

from __future__ import annotations

import pytest

from navbench.errors import ConfigError
from navbench.levelgen.changed import change_level
from navbench.levelgen.validate import validate_level
from navbench.levelio import dumps_level, load_level, level_from_dict


@pytest.fixture(scope="module")
def base():
    return load_level("levels/house-1.json")


def test_changed_level_is_deterministic_valid_and_changed(base):
    import json

    a = change_level(base, "house-1-changed", 6, seed=3)
    b = change_level(base, "house-1-changed", 6, seed=3)
    assert dumps_level(a) == dumps_level(b)
    assert dumps_level(change_level(base, "house-1-changed", 6, seed=4)) != dumps_level(a)
    validate_level(a)
    assert a.walls == base.walls and a.obstacles != base.obstacles
    assert a.textures[: len(base.textures)] == base.textures
    assert a.meta["changed_from"] == "house-1" and len(a.meta["change_log"]) == 6
    ops = {e["op"] for e in a.meta["change_log"]}
    assert ops <= {"add", "move", "remove"}
    n_add = sum(e["op"] == "add" for e in a.meta["change_log"])
    n_rm = sum(e["op"] == "remove" for e in a.meta["change_log"])
    assert len(a.obstacles) == len(base.obstacles) + n_add - n_rm
    again = level_from_dict(json.loads(dumps_level(a)))  # a valid level file
    assert dumps_level(again) == dumps_level(a)


def test_zero_changes_is_the_base_renamed(base):
    a = change_level(base, "same", 0, seed=0)
    assert a.obstacles == base.obstacles and a.name == "same"


def test_bad_change_count(base):
    with pytest.raises(ConfigError, match="--changes"):
        change_level(base, "x", 1000, seed=0)
