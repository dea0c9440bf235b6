"""Issue 35 §2: ``--set KEY=VALUE`` overrides and profile inheritance (``extends``)."""

from __future__ import annotations

import json

import pytest

from navbench.errors import ConfigError
from navbench.pipeline.overrides import apply_sets
from navbench.pipeline.profiles import load_profile
from tests.bad_input.conftest import project  # noqa: F401  (the scratch-project fixture)


def test_set_reads_each_key_by_its_fields_type():
    p = load_profile("quick")
    q = apply_sets(p, ["fit.steps=300", "tasks.count=3", "navigation.estimators=ours,gt",
                       "levels=house-1,house-2", "fit.lr=0.05", "navigation.episode.max_steps=300",
                       "navigation.options.ours.optimizer=adam", "views.camera=paper",
                       "conditions.pose_quantisation=round", "scoring.preset=nrns"])
    assert q.fit_steps == 300 and q.tasks == 3 and q.estimators == ("ours", "gt")
    assert q.levels == ("house-1", "house-2") and q.fit == {"lr": 0.05} and q.camera == "paper"
    # quick runs under the default version (navbench-5): its settings stay beside what --set writes
    assert q.episode == {"texture": "table", "max_steps": 300, "pose_quantisation": "round"}
    assert q.estimator_options == {"ours": {"yaw_search_spread": True, "optimizer": "adam"},
                                   "no-map": {"yaw_search_spread": True}} and q.scoring_preset == "nrns"
    # the rest is the profile's, and the profile itself is unchanged
    assert (q.views, q.tasks_seed, q.noise, q.name) == (p.views, p.tasks_seed, p.noise, p.name)
    assert p.fit_steps == 2000 and apply_sets(p, []) is p
    # later items win
    assert apply_sets(p, ["tasks.count=3", "tasks.count=4"]).tasks == 4


@pytest.mark.parametrize("item,names", [
    ("taks.count=3", ["--set taks.count", "did you mean 'tasks.count'", "fit.steps", "conditions.<name>"]),
    ("fit.steps=fifty", ["--set fit.steps=fifty", "expected an integer", "'fifty'"]),
    ("fit.steps=nan", ["--set fit.steps=nan", "expected an integer"]),
    ("fit.lr=inf", ["--set fit.lr=inf", "lr", "got inf"]),
    ("fit.lr=nan", ["--set fit.lr=nan", "got nan"]),
    ("navigation.estimators=ourss", ["unknown estimator 'ourss'", "did you mean 'ours'"]),
    ("levels=", ["--set levels=", "at least one level"]),
    ("tasks.count", ["--set tasks.count", "KEY=VALUE"]),
    ("views.eval_seed=0", ["--set", "eval_seed must differ"]),
    ("navigation.options.ours=1", ["navigation.options.<estimator>.<option>"]),
])
def test_set_refuses_what_a_profile_refuses(item, names):
    with pytest.raises(ConfigError) as e:
        apply_sets(load_profile("quick"), [item])
    msg = str(e.value)
    assert "\n" not in msg
    for n in names:
        assert n in msg, (n, msg)


def test_extends_a_bundled_profile_and_a_relative_path(project, tmp_path):
    (project / "mini.toml").write_text('extends = "quick"\n[tasks]\ncount = 3\n')
    mini = load_profile("mini.toml")
    quick = load_profile("quick")
    assert mini.name == "mini" and mini.tasks == 3  # the file's stem; the one changed field
    assert {**vars(mini), "name": "", "tasks": 0} == {**vars(quick), "name": "", "tasks": 0}
    # a path relative to the extending file (not the working directory), tables merged by key
    sub = project / "sub"
    sub.mkdir()
    (sub / "child.toml").write_text('extends = "../tiny.toml"\nname = "kid"\n[fit]\nsteps = 5\n')
    kid = load_profile(str(sub / "child.toml"))
    tiny = load_profile("tiny.toml")
    assert kid.name == "kid" and kid.fit_steps == 5 and kid.fit == tiny.fit and kid.levels == tiny.levels
    # a profile without extends needs no name either
    (project / "plain.toml").write_text('levels = ["tiny"]\n')
    assert load_profile("plain.toml").name == "plain"


def test_extends_cycles_and_missing_parents_are_one_line(project):
    (project / "a.toml").write_text('extends = "b.toml"\n')
    (project / "b.toml").write_text('extends = "a.toml"\n')
    with pytest.raises(ConfigError, match=r"cycle: a\.toml -> b\.toml -> a\.toml"):
        load_profile("a.toml")
    (project / "c.toml").write_text('extends = "c.toml"\n')
    with pytest.raises(ConfigError, match="cycle"):
        load_profile("c.toml")
    (project / "d.toml").write_text('extends = "quik"\n')
    with pytest.raises(ConfigError, match=r"d\.toml: extends: unknown profile 'quik' \(did you mean 'quick'\?\)"):
        load_profile("d.toml")
    (project / "e.toml").write_text('extends = "nope/x.toml"\n')
    with pytest.raises(ConfigError, match=r"e\.toml: extends nope/x\.toml: no such file"):
        load_profile("e.toml")
    (project / "f.toml").write_text('extends = "quick"\n[fit]\nstepz = 3\n')
    with pytest.raises(ConfigError, match=r"f\.toml: \[fit\] stepz: unknown field"):
        load_profile("f.toml")


def test_missing_profile_file_is_named_as_missing(project):
    with pytest.raises(ConfigError, match=r"--profile /missing/file\.toml: no such file"):
        load_profile("/missing/file.toml")


def test_set_fit_steps_changes_the_fit_key_and_nothing_upstream(project):
    """The override flows through the config -> cache key hashing: the map's key changes, the
    level's, the views' and the task set's do not."""
    from navbench.pipeline.run import stage_context
    from navbench.pipeline.stages import build_level_inputs

    ctx = stage_context()
    base = load_profile("tiny.toml")
    changed = apply_sets(base, ["fit.steps=2"])
    a = build_level_inputs(ctx, base, "tiny")
    b = build_level_inputs(ctx, changed, "tiny")
    assert a.map.key != b.map.key
    assert (a.level.key, a.tasks.key) == (b.level.key, b.tasks.key)

    def views(ref):
        return json.loads((ref.path.parent / "manifest.json").read_text())["inputs"]

    assert views(a.map) == views(b.map)  # the same level and views went into both fits
    assert json.loads((b.map.path.parent / "manifest.json").read_text())["config"]["fit"]["steps"] == 2
