"""make-level and show-level through the CLI, in a temporary working directory."""

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from navbench.cli.main import app, main
from navbench.levelgen import BENCHMARK_LEVELS

REPO = Path(__file__).resolve().parents[2]
FIXTURE = REPO / "tests" / "fixtures" / "houseexpo_small.json"


@pytest.fixture
def cwd(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_make_level_writes_and_refuses_to_overwrite(cwd):
    r = CliRunner().invoke(app, ["make-level", "small", "--seed", "2", "--size", "8",
                                 "--rooms", "4", "--obstacles", "5"])
    assert r.exit_code == 0, r.output
    path = cwd / "levels" / "small.json"
    assert path.is_file()
    assert "4 rooms" in r.output and "5 obstacles" in r.output
    first = path.read_text()
    r = CliRunner().invoke(app, ["make-level", "small", "--seed", "2", "--size", "8",
                                 "--rooms", "4", "--obstacles", "5"])
    assert r.exit_code == 0 and "unchanged" in r.output
    with pytest.raises(SystemExit) as e:
        main(["make-level", "small", "--seed", "3", "--size", "8", "--rooms", "4", "--obstacles", "5"])
    assert e.value.code == 2
    assert path.read_text() == first
    r = CliRunner().invoke(app, ["make-level", "small", "--seed", "3", "--size", "8",
                                 "--rooms", "4", "--obstacles", "5", "--force"])
    assert r.exit_code == 0 and "replaced" in r.output
    assert path.read_text() != first


def test_refusal_is_one_line(cwd, capsys):
    (cwd / "levels").mkdir()
    (cwd / "levels" / "x.json").write_text("{}")
    with pytest.raises(SystemExit) as e:
        main(["make-level", "x", "--seed", "1", "--kind", "maze", "--size", "4.9"])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--force" in err


def test_benchmark_regeneration_matches_committed_files(cwd):
    r = CliRunner().invoke(app, ["make-level", "--benchmark"])
    assert r.exit_code == 0, r.output
    for name in BENCHMARK_LEVELS:
        assert (cwd / "levels" / f"{name}.json").read_text() == (REPO / "levels" / f"{name}.json").read_text()


def test_show_level_writes_png(cwd):
    r = CliRunner().invoke(app, ["make-level", "m", "--seed", "1", "--kind", "maze", "--size", "4.9"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(app, ["show-level", "m"])
    assert r.exit_code == 0, r.output
    png = cwd / "results" / "levels" / "m.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    r = CliRunner().invoke(app, ["show-level", "levels/m.json", "--out", "top.png", "--doors"])
    assert r.exit_code == 0, r.output
    assert (cwd / "top.png").read_bytes()[:4] == b"\x89PNG"


def test_from_houseexpo(cwd):
    r = CliRunner().invoke(app, ["make-level", "hx", "--seed", "1", "--from-houseexpo", str(FIXTURE),
                                 "--obstacles", "4"])
    assert r.exit_code == 0, r.output
    doc = json.loads((cwd / "levels" / "hx.json").read_text())
    assert doc["meta"]["generator"] == "navbench.levelgen.houseexpo"


def test_malformed_files_give_one_line_errors(cwd, capsys):
    bad = cwd / "bad.json"
    bad.write_text(json.dumps({"schema_version": 1, "name": "b", "width": 3, "depth": 3,
                               "textures": [], "floor_texture": 0}))
    with pytest.raises(SystemExit) as e:
        main(["show-level", str(bad)])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "textures" in err
    hx = cwd / "hx.json"
    hx.write_text(json.dumps({"bbox": {"min": [0, 0], "max": [1, 1]}}))
    with pytest.raises(SystemExit) as e:
        main(["make-level", "hx", "--seed", "1", "--from-houseexpo", str(hx)])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "verts" in err


def test_usage_errors(cwd):
    with pytest.raises(SystemExit) as e:
        main(["make-level", "x"])
    assert e.value.code == 2
    with pytest.raises(SystemExit) as e:
        main(["make-level", "x", "--seed", "1", "--kind", "maze", "--rooms", "3"])
    assert e.value.code == 2
