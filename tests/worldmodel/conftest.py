"""Fixtures for the world-model tests."""

from __future__ import annotations

import pytest

from wm_levels import room_level


@pytest.fixture(scope="session")
def room():
    return room_level()
