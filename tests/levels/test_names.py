"""navbench.names: the one safe-name rule for names that become file names."""

from __future__ import annotations

import pytest

from navbench.errors import ConfigError, LevelError
from navbench.names import check_name, is_safe_name


@pytest.mark.parametrize("name", ["house-1", "maze", "tiny", "door-rooms", "a.b_c-9", "A" * 64])
def test_safe_names_pass(name):
    assert is_safe_name(name)
    assert check_name("level name", name) == name


@pytest.mark.parametrize("name", ["", "../../x", "/tmp/x", "a/b", "a\\b", "..", "a..b", ".hidden",
                                  "-x", "a b", "A" * 65, "x[/x]", "é", None, 3, "a\n"])
def test_unsafe_names_are_rejected_with_the_kind_named(name):
    assert not is_safe_name(name)
    with pytest.raises(ConfigError, match="level name .* is not a safe name"):
        check_name("level name", name)
    with pytest.raises(LevelError, match=r"^levels/a.json: name "):
        check_name("levels/a.json: name", name, LevelError)
