"""Issue 35 §4/§5 in library use: run_profile's progress (off by default, the CLI's lines and bars
with progress=True, text lines to a callback), the report where the CLI puts it, and the line
before a benchmark level is generated in a folder without levels/."""

from __future__ import annotations

from navbench.pipeline.run import run_profile
from tests.bad_input.conftest import project  # noqa: F401  (the scratch-project fixture)


def test_progress_callback_true_and_silent_and_report_path(project, capsys):
    lines: list[str] = []
    url = f"sqlite:///{project / 'lib.db'}"
    result = run_profile("tiny.toml", db=url, progress=lines.append, sets=["tasks.count=1"])
    assert result.navigation.total == 2 and result.profile.tasks == 1
    assert any(ln.startswith("fit-map: computing") for ln in lines)
    assert "episodes 2/2" in lines and any(ln.startswith("fit tiny 3/3") for ln in lines)
    # the page `navbench all` names by default (results/report), not the cached one
    assert result.report_path.resolve() == project / "results" / "report" / "index.html"
    assert result.report_path.is_file()
    assert capsys.readouterr().out == ""  # a callback, not the console

    again = run_profile("tiny.toml", db=url, until="score", progress=True, sets=["tasks.count=1"])
    out = capsys.readouterr().out
    assert again.navigation.already_done == 2
    assert "fit-map: cached" in out and "run-navigation: 2 episodes" in out

    run_profile("tiny.toml", db=url, until="score", sets=["tasks.count=1"])
    assert capsys.readouterr() == ("", "")  # library use: silent by default


def test_a_level_generated_outside_a_project_says_so_first(tmp_path):
    from navbench.pipeline.run import stage_context
    from navbench.pipeline.stages import LevelConfig, make_level_stage

    lines: list[str] = []

    class Lines:
        def log(self, msg):
            lines.append(msg)

    ctx = stage_context(Lines(), cache_root=tmp_path / "cache", levels_dir=tmp_path / "levels")
    make_level_stage(ctx, LevelConfig("house-1"))
    assert lines[0].startswith(f"warning: {tmp_path / 'levels'} does not exist")
    assert "house-1" in lines[0] and str(tmp_path / "cache") in lines[0] and "\n" not in lines[0]
