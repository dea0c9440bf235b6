"""Dependencies (issue 12, item 8): bounded ranges for a library, exact torch for `make setup`,
ray and the PostgreSQL driver only as extras, nothing imported that is not declared."""

from __future__ import annotations

import ast
import importlib.metadata as md
import sys
from pathlib import Path

from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[2]


def _requirements() -> list[Requirement]:
    return [Requirement(r) for r in md.requires("navbench") or []]


def _base(reqs):
    """The requirements a plain ``pip install navbench`` (no extras) installs."""
    return [r for r in reqs if r.marker is None or r.marker.evaluate({"extra": ""})]


def test_torch_requirement_is_a_bounded_range():
    torch = [r for r in _requirements() if r.name == "torch"]
    assert len(torch) == 1
    ops = {s.operator for s in torch[0].specifier}
    assert ">=" in ops and "<" in ops and "==" not in ops, str(torch[0].specifier)
    # the range admits the version make setup installs, and not the next major
    assert torch[0].specifier.contains("2.13.0") and not torch[0].specifier.contains("3.0.0")


def test_every_requirement_has_a_lower_bound_and_typer_an_upper_one():
    for r in _base(_requirements()):
        assert any(s.operator == ">=" for s in r.specifier), f"{r} has no lower bound"
    typer = next(r for r in _requirements() if r.name == "typer")
    assert any(s.operator == "<" for s in typer.specifier), str(typer)


def test_ray_and_psycopg_are_extras_only():
    base = {r.name for r in _base(_requirements())}
    assert not base & {"ray", "psycopg", "psycopg2", "tomli-w", "tomli_w"}, base
    extras = {r.name for r in _requirements()} - base
    assert {"ray", "psycopg"} <= extras


def test_make_setup_installs_exactly_torch_2_13_0():
    """constraints.txt pins torch==2.13.0 and the Makefile installs through it; where this venv
    is the one `make setup` built (its stamp exists), the installed torch is exactly that."""
    assert "torch==2.13.0" in (ROOT / "constraints.txt").read_text().split()
    assert "-c constraints.txt" in (ROOT / "Makefile").read_text()
    if (Path(sys.prefix) / ".installed").is_file():
        assert md.version("torch").split("+")[0] == "2.13.0", md.version("torch")


def _top_level_imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def test_the_package_imports_only_what_it_declares():
    """Every third-party module imported under navbench/ is a declared requirement (extras
    included: those imports sit behind the option that needs them) or the standard library."""
    declared = {r.name.lower().replace("-", "_") for r in _requirements()}
    module_of = {"pillow": "PIL"}   # distribution name -> module name, where they differ
    declared_modules = {module_of.get(d, d) for d in declared}
    imported = set()
    for p in (ROOT / "navbench").rglob("*.py"):
        imported |= _top_level_imports(p)
    stdlib = set(sys.stdlib_module_names)
    third_party = {m for m in imported if m not in stdlib and m != "navbench" and not m.startswith("_")}
    undeclared = third_party - declared_modules
    assert not undeclared, f"imported but not declared: {sorted(undeclared)}"
