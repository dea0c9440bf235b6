"""The estimator registry (issue 12): capabilities as class attributes, names checked with the
list of known names, plugins found through the ``navbench.estimators`` entry points (faked here
by replacing :func:`importlib.metadata.entry_points`), broken plugins as one clean line."""

from __future__ import annotations

import importlib.metadata
from dataclasses import dataclass
from types import SimpleNamespace

import pytest

from navbench.errors import ConfigError, PluginError, TrackingError
from navbench.plugins import ESTIMATORS_GROUP, WORLD_MODELS_GROUP, find_plugins, load_entry_points
from navbench.track import registry
from tests.bad_input.conftest import assert_clean_error, nb, tree_snapshot

BUILTINS = ["dynamics", "emission", "gt", "no-map", "ours"]


@dataclass(frozen=True)
class GoodOptions:
    gain: float = 1.0


class GoodPlugin:
    """A frameless, mapless estimator with one option (it only has to be constructible)."""

    uses_frames = False
    uses_map = False
    options = GoodOptions

    def __init__(self, vmap=None, intrinsics=None, camera_height=0.0, renderer=None, seed=0, **options):
        self.opts = GoodOptions(**options)

    def reset(self, pose0, frame0=None):
        pass

    def update(self, control, frame=None, true_pose=None):
        return true_pose


class NoCapabilities:
    def reset(self, pose0, frame0=None):
        pass

    def update(self, control, frame=None, true_pose=None):
        return true_pose


def fake_entry_points(monkeypatch, *eps: tuple[str, str, str]):
    """Make ``importlib.metadata.entry_points(group=...)`` return ``(group, name, value)``
    entries of a distribution ``fake-dist 1.2``."""
    dist = SimpleNamespace(metadata={"Name": "fake-dist"}, version="1.2")
    entries = [SimpleNamespace(group=g, name=n, value=v, dist=dist) for g, n, v in eps]

    def entry_points(group=None):
        return [e for e in entries if e.group == group]

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    registry.reset_plugins()


# ------------------------------------------------------------------ built-ins

@pytest.mark.parametrize("name, frames, vmap, options", [
    ("gt", False, False, None),
    ("dynamics", False, False, None),
    ("ours", True, True, "TrackerConfig"),
    ("no-map", True, False, "FrameToFrameConfig"),  # TrackerConfig without reference_scale (issue 17)
    ("emission", True, True, "EmissionConfig"),
])
def test_builtin_capabilities_are_class_attributes(name, frames, vmap, options):
    cls = registry.estimator_class(name)
    assert cls.name == name
    assert cls.uses_frames is frames and registry.uses_frames(name) is frames
    assert cls.uses_map is vmap and registry.uses_map(name) is vmap
    opts = registry.estimator_options_config(name)
    assert (opts.__name__ if opts is not None else None) == options
    assert opts is cls.options


def test_known_estimators_and_the_unknown_name_message():
    assert registry.known_estimators() == BUILTINS
    with pytest.raises(TrackingError) as e:
        registry.estimator_class("nope")
    assert str(e.value) == "unknown estimator 'nope' (known: dynamics, emission, gt, no-map, ours)"
    with pytest.raises(ConfigError, match=r"^--estimators: unknown estimator 'ourz' \(known: dyn"):
        registry.check_estimator_names(["ours", "ourz"], "--estimators")


def test_make_estimator_builds_the_registered_class():
    assert type(registry.make_estimator("gt")) is registry.estimator_class("gt")


# ------------------------------------------------------------------ plugins

def test_a_plugin_is_found_checked_and_built(monkeypatch):
    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "good", f"{__name__}:GoodPlugin"))
    assert registry.known_estimators() == sorted(BUILTINS + ["good"])
    est = registry.make_estimator("good", gain=2.0)
    assert isinstance(est, GoodPlugin) and est.opts.gain == 2.0
    assert GoodPlugin.name == "good"  # the entry point's name, given to a class without one
    assert registry.uses_frames("good") is False
    assert registry.estimator_options_config("good") is GoodOptions


def test_a_broken_plugin_is_one_line_naming_it_and_its_distribution(monkeypatch):
    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "broken", "navbench_no_such_module:Tracker"))
    assert "broken" in registry.known_estimators()  # listing does not import
    with pytest.raises(PluginError) as e:
        registry.estimator_class("broken")
    msg = str(e.value)
    assert "\n" not in msg
    for part in ("'broken'", "navbench_no_such_module:Tracker", "fake-dist 1.2", "ModuleNotFoundError"):
        assert part in msg, msg
    assert "unknown estimator" not in msg


def test_a_broken_plugin_fails_the_cli_before_any_stage(monkeypatch, project, tmp_path):
    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "broken", "navbench_no_such_module:Tracker"))
    before = tree_snapshot(tmp_path)
    res = nb("run-navigation", "--profile", "tiny.toml", "--estimators", "gt,broken")
    assert_clean_error(res, "--estimators", "'broken'", "fake-dist 1.2", "ModuleNotFoundError")
    assert tree_snapshot(tmp_path) == before
    # an unrelated broken plugin does not stop runs that do not use it; its name is listed
    res = nb("run-navigation", "--profile", "tiny.toml", "--estimators", "nope")
    assert_clean_error(res, "--estimators", "unknown estimator 'nope'",
                       "(known: broken, dynamics, emission, gt, no-map, ours)")


def test_track_eval_lists_plugins_among_the_known_names(monkeypatch, project):
    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "good", f"{__name__}:GoodPlugin"))
    res = nb("track-eval", "tiny", "--estimators", "good,ourz")
    assert_clean_error(res, "--estimators", "unknown estimator 'ourz'", "good, gt")


@pytest.mark.parametrize("value, expected", [
    (f"{__name__}:NoCapabilities", "must declare uses_frames"),
    (f"{__name__}:GoodOptions", "must declare uses_frames"),
    (f"{__name__}:fake_entry_points", "expected an estimator class"),
    (f"{__name__}:Missing", "AttributeError"),
])
def test_a_plugin_must_declare_its_capabilities(monkeypatch, value, expected):
    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "bad", value))
    with pytest.raises(PluginError, match=expected):
        registry.estimator_class("bad")


def test_a_plugin_clashing_with_a_builtin_is_an_error(monkeypatch):
    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "ours", f"{__name__}:GoodPlugin"))
    with pytest.raises(PluginError, match="fake-dist 1.2.*'ours' is a built-in estimator"):
        registry.known_estimators()


def test_two_plugins_of_one_name_and_unsafe_names_are_errors(monkeypatch):
    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "twin", "a:A"), (ESTIMATORS_GROUP, "twin", "b:B"))
    with pytest.raises(PluginError, match="'twin' is declared twice"):
        registry.known_estimators()
    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "twin", "a:A"), (ESTIMATORS_GROUP, "twin", "a:A"))
    assert "twin" in registry.known_estimators()  # one distribution seen twice on sys.path
    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "../x", "a:A"))
    with pytest.raises(PluginError, match="not a safe name"):
        registry.known_estimators()


def test_load_entry_points_serves_any_group(monkeypatch):
    fake_entry_points(monkeypatch, (WORLD_MODELS_GROUP, "grid", f"{__name__}:GoodOptions"),
                      (ESTIMATORS_GROUP, "good", f"{__name__}:GoodPlugin"))
    assert list(find_plugins(WORLD_MODELS_GROUP)) == ["grid"]
    assert load_entry_points(WORLD_MODELS_GROUP) == {"grid": GoodOptions}
    fake_entry_points(monkeypatch, (WORLD_MODELS_GROUP, "grid", "navbench_no_such_module:Grid"))
    with pytest.raises(PluginError, match="navbench.world_models plugin 'grid'"):
        load_entry_points(WORLD_MODELS_GROUP)


def test_profile_options_of_a_plugin_are_checked_against_its_dataclass(monkeypatch):
    from navbench.pipeline.profiles import check_field

    fake_entry_points(monkeypatch, (ESTIMATORS_GROUP, "good", f"{__name__}:GoodPlugin"))
    check_field("estimator_options", {"good": {"gain": 0.5}}, "p.toml")
    with pytest.raises(ConfigError, match=r"p.toml: \[navigation.options.good\] speed: unknown field"):
        check_field("estimator_options", {"good": {"speed": 1}}, "p.toml")
