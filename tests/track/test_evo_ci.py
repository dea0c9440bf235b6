"""CI installs evo, so tests/track/test_evo.py runs there rather than skipping."""


def test_ci_installs_evo():
    """``make setup`` (CI's ``make test``) installs the test extra, which holds evo, pinned in
    constraints.txt; this test file then runs instead of skipping."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    assert "evo==1.31.0" in (root / "constraints.txt").read_text().split()
    test_extra = [ln for ln in (root / "pyproject.toml").read_text().splitlines() if ln.startswith("test =")]
    assert test_extra and '"evo>=1.31"' in test_extra[0]
