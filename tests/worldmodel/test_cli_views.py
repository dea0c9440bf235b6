"""CLI: export-views and import-views through typer's runner."""

from __future__ import annotations

import numpy as np
from typer.testing import CliRunner

from navbench.cli.main import app
from navbench.geometry import Intrinsics
from navbench.worldmodel.views import collect_views, load_views, save_views


def test_export_then_import_cli(tmp_path, room):
    v = collect_views(room, 3, Intrinsics(16, 12, 7.5, 7.5, 8.0, 6.0), seed=0)
    save_views(v, tmp_path / "v")
    r = CliRunner().invoke(app, ["export-views", str(tmp_path / "v"), str(tmp_path / "tum")])
    assert r.exit_code == 0, r.output
    (tmp_path / "tum" / "intrinsics.json").unlink()
    r = CliRunner().invoke(app, ["import-views", str(tmp_path / "tum"), "--out", str(tmp_path / "w.npz"),
                                 "--fx", "7.5", "--cx", "8", "--cy", "6", "--camera-height", "0.5"])
    assert r.exit_code == 0, r.output
    w = load_views(tmp_path / "w.npz")
    assert w.intrinsics == v.intrinsics and len(w) == 3
    np.testing.assert_array_equal(w.rgb, v.rgb)
    np.testing.assert_allclose(w.poses, v.poses, atol=1e-7)


def test_import_missing_directory_is_a_one_line_error(tmp_path):
    from navbench.cli.main import main
    import pytest

    with pytest.raises(SystemExit) as e:
        main(["import-views", str(tmp_path / "nope"), "--out", str(tmp_path / "x")])
    assert e.value.code == 2
