"""The hand-made levels of the planning tests, shared with the navigation tests."""

from tests.plan.levels import door_rooms, open_room, two_rooms  # noqa: F401
