"""``navbench sample-tasks`` through typer's CliRunner."""

from __future__ import annotations

from typer.testing import CliRunner

from navbench.cli.main import app
from navbench.levelio import save_level
from navbench.plan.tasks import level_sha256, read_task_file

from .levels import door_rooms


def test_sample_tasks_writes_a_named_task_file(tmp_path):
    lv = save_level(door_rooms(), tmp_path / "door-rooms.json")
    res = CliRunner().invoke(app, ["sample-tasks", str(lv), "--count", "5", "--seed", "2",
                                   "--out", str(tmp_path / "tasks")])
    assert res.exit_code == 0, res.output
    files = list((tmp_path / "tasks").glob("door-rooms-5-*.json"))
    assert len(files) == 1 and str(files[0].name) in res.output.replace("\n", "")
    ts = read_task_file(files[0])
    assert ts.count == 5 and ts.seed == 2 and ts.level_sha256 == level_sha256(lv.read_text())


def test_missing_level_is_a_one_line_error(tmp_path, capsys):
    import pytest

    from navbench.cli.main import main

    with pytest.raises(SystemExit) as e:
        main(["sample-tasks", str(tmp_path / "nope.json")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no such level file" in err
