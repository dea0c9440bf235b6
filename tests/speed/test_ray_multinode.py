"""Ray across two nodes (issue 17): a head and a worker node on this machine run the refactoring
guard's grid with ``--executor ray --address ...``; the stored rows equal the local executor's
bit for bit (docs/data/ray/ray_two_nodes.py, which starts and shuts down exactly its own two nodes)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
@pytest.mark.xdist_group("ray")  # never beside the other Ray test: two clusters at once collide
def test_two_ray_nodes_store_the_local_executors_rows():
    pytest.importorskip("ray", reason="ray is not installed (optional extra navbench[ray])")
    res = subprocess.run([sys.executable, str(ROOT / "docs" / "data" / "ray" / "ray_two_nodes.py")], cwd=ROOT,
                         capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stdout + res.stderr
    assert ": 2 nodes (" in res.stdout
    assert "24 rows with --executor local --workers 2, 24 with --executor ray; identical: True" in res.stdout
