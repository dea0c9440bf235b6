"""Bad input for issue 17, part 2: ours' option ``reference_scale`` in a profile (one line naming
the file, the section and the option; nothing written)."""

from __future__ import annotations

import pytest

from tests.bad_input.conftest import assert_clean_error, nb, tree_snapshot
from tests.bad_input.test_profiles_cli import variant

CASES = [
    ("ours", "0", "reference_scale"),
    ("ours", "1.5", "reference_scale"),
    ("ours", "-0.5", "reference_scale"),
    ("ours", '"half"', "reference_scale"),
    ("no-map", "0.5", "reference_scale"),
]


@pytest.mark.parametrize("est,value,name", CASES, ids=[f"{c[0]}={c[1]}" for c in CASES])
def test_bad_reference_scale_is_one_line(project, tmp_path, est, value, name):
    (project / "bad.toml").write_text(variant(f"navigation.options.{est}", "reference_scale", value))
    before = tree_snapshot(tmp_path)
    res = nb("run-navigation", "--profile", "bad.toml")
    assert_clean_error(res, "bad.toml", f"[navigation.options.{est}]", name)
    assert tree_snapshot(tmp_path) == before


def test_reference_scale_with_health_is_one_line(project, tmp_path):
    text = variant("navigation.options.ours", "reference_scale", "0.5")
    (project / "bad.toml").write_text(variant("navigation.options.ours", "health", "true", text))
    res = nb("run-navigation", "--profile", "bad.toml")
    assert_clean_error(res, "bad.toml", "[navigation.options.ours]", "health")


def test_valid_reference_scale_loads(project):
    from navbench.pipeline.profiles import load_profile

    # under navbench-1, whose settings table is empty: only what the file writes
    (project / "ok.toml").write_text(variant("", "benchmark_version", '"navbench-1"',
                                             variant("navigation.options.ours", "reference_scale", "0.5")))
    assert load_profile("ok.toml").estimator_options == {"ours": {"reference_scale": 0.5}}


@pytest.mark.parametrize("content", [None, b"not a zip"], ids=["missing", "junk"])
def test_bench_map_file_is_checked_before_a_run_is_recorded(project, tmp_path, content):
    """``bench --map FILE``: a missing or malformed map is one line naming the file, before the
    bench records a run or times anything."""
    if content is not None:
        (project / "m.npz").write_bytes(content)
    before = tree_snapshot(tmp_path)
    res = nb("bench", "--quick", "--level", "tiny", "--map", "m.npz")
    assert_clean_error(res, "m.npz")
    assert tree_snapshot(tmp_path) == before


def test_bench_map_file_is_the_map_timed(project):
    """``bench_map`` with a file returns that map and names it (runs on one file compare)."""
    from navbench.bench.timers import bench_map
    from navbench.levelio import resolve_level
    from navbench.worldmodel.grid import voxelize_level

    vmap = voxelize_level(resolve_level("tiny"))
    vmap.save(project / "tiny.npz")
    got, desc = bench_map(None, None, "results/cache", project / "tiny.npz")
    assert desc.startswith(f"map file {project / 'tiny.npz'} (") and "x" in desc
    assert got.spec == vmap.spec and (got.occ == vmap.occ).all()
