"""scripts/_env.py: the PYTHONPATH that scripts and tests give navbench subprocesses keeps the one
already set (the GPU machine's run found three tests that replaced it and lost sqlalchemy)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from scripts._env import pythonpath_first


def test_paths_go_first_and_the_existing_pythonpath_is_kept(monkeypatch, tmp_path):
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(["/deps/a", "/deps/b"]))
    assert pythonpath_first(tmp_path, "/code") == os.pathsep.join([str(tmp_path), "/code", "/deps/a", "/deps/b"])
    monkeypatch.delenv("PYTHONPATH")
    assert pythonpath_first(tmp_path) == str(tmp_path)


def test_a_child_imports_a_module_only_the_old_pythonpath_holds(monkeypatch, tmp_path):
    deps = tmp_path / "deps"
    deps.mkdir()
    (deps / "only_here.py").write_text("VALUE = 7\n")
    monkeypatch.setenv("PYTHONPATH", str(deps))
    env = {**os.environ, "PYTHONPATH": pythonpath_first(Path(__file__).resolve().parents[1])}
    out = subprocess.run([sys.executable, "-c", "import only_here; print(only_here.VALUE)"],
                         env=env, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "7"
