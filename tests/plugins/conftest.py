"""Fixtures of the plugin tests: the probe project of tests/bad_input, and a registry that
forgets the plugins it found before and after every test (tests fake the entry points)."""

from __future__ import annotations

import pytest

from tests.bad_input.conftest import project  # noqa: F401  (the scratch project fixture)


@pytest.fixture(autouse=True)
def fresh_registry():
    from navbench.track.registry import reset_plugins

    reset_plugins()
    yield
    reset_plugins()
