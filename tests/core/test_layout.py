"""The package's shape (issue 12): no module above 600 lines, no import cycle between modules.

Imports are read from the source (``ast``), module-level and function-level alike: an import
deferred into a function still couples the two modules, so a cycle through it is still a
layering bug (math -> stages -> CLI, one direction)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "navbench"
MAX_LINES = 600


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in PKG.rglob("*.py")}


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """navbench modules imported anywhere in ``path`` (``from a import b`` counts a.b when that
    is a module, else a)."""
    is_pkg = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = name.split(".") if is_pkg else name.split(".")[:-1]
                pkg = pkg[: len(pkg) - (node.level - 1)]
                base = ".".join(pkg + ([base] if base else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        for t in targets:
            while t and t not in known:
                t = t.rpartition(".")[0]
            if t and t != name and t.startswith("navbench"):
                out.add(t)
    return out


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    known = set(mods)
    g = {m: _imports(m, p, known) for m, p in mods.items()}
    # a package's __init__ importing its own submodules is how packages work, not a cycle
    return {m: {t for t in ts if not t.startswith(m + ".")} for m, ts in g.items()}


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_cycle_finder_finds_a_cycle():
    assert find_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert find_cycles({"a": {"b"}, "b": set()}) == []


def test_no_module_above_600_lines():
    long = {str(p.relative_to(ROOT)): n for p in PKG.rglob("*.py")
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules above {MAX_LINES} lines: {long}"


def test_no_import_cycle():
    cycles = find_cycles(_graph())
    assert not cycles, f"import cycles: {cycles}"


#: The floors, lowest first: a module may import its own floor and those below, never above.
#: ``navbench.proc``, ``paper``, ``errors``, ``names``, ``config``, ``geometry`` and the level
#: modules are the ground every floor stands on.
FLOORS = [
    ("math", ("navbench.sim", "navbench.worldmodel", "navbench.plan", "navbench.nav", "navbench.track",
              "navbench.localize", "navbench.levelgen")),
    ("results", ("navbench.results",)),
    ("report", ("navbench.report",)),
    ("pipeline", ("navbench.pipeline",)),
    ("bench", ("navbench.bench",)),
    ("cli", ("navbench.cli",)),
]


def _floor(module: str) -> int | None:
    for i, (_, prefixes) in enumerate(FLOORS):
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return i
    return None


def test_imports_point_down():
    """math -> results -> report -> pipeline -> bench -> CLI: no module imports a floor above its
    own (deferred imports inside functions included)."""
    up = []
    for mod, targets in _graph().items():
        f = _floor(mod)
        for t in targets:
            ft = _floor(t)
            if f is not None and ft is not None and ft > f:
                up.append(f"{mod} -> {t}")
    assert not up, "imports pointing up a floor:\n" + "\n".join(sorted(up))


def test_floor_checker_sees_an_upward_import():
    assert _floor("navbench.results.score") < _floor("navbench.pipeline.cache")
    assert _floor("navbench.nav.presets") < _floor("navbench.results.presets")


def test_pipeline_neither_scores_reports_nor_plots():
    """``navbench/pipeline/`` is orchestration: no module there imports matplotlib, and the only
    modules named after scoring or the report are the two stages that call down into
    :mod:`navbench.results` and :mod:`navbench.report`."""
    stages_calling_down = {"navbench.pipeline.stages.score", "navbench.pipeline.stages.report"}
    offenders = []
    for p in (PKG / "pipeline").rglob("*.py"):
        name = _module_name(p)
        text = p.read_text()
        if "matplotlib" in text:
            offenders.append(f"{name} uses matplotlib")
        stem = p.stem
        if any(w in stem for w in ("score", "report", "plot", "breakdown", "preset", "table")) \
                and name not in stages_calling_down:
            offenders.append(f"{name} is named as results/report code")
    assert not offenders, offenders
    for name in stages_calling_down:
        path = PKG / "pipeline" / "stages" / (name.rsplit(".", 1)[1] + ".py")
        assert len(path.read_text().splitlines()) < 80, f"{name} should only call down"


def test_moved_modules_still_import_with_a_warning():
    """Every old path of a moved module answers with the module at its new path (the same object)
    and a DeprecationWarning naming the new one."""
    import importlib
    import sys
    import warnings

    from navbench import _moved

    for old, new in _moved.MOVED.items():
        sys.modules.pop(old, None)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mod = importlib.import_module(old)
        assert mod is importlib.import_module(new), old
        assert mod.__spec__.name == new, f"{new}'s spec was overwritten by the alias {old}"
        assert any(issubclass(w.category, DeprecationWarning) and new in str(w.message) for w in caught), old
        assert not (PKG / Path(*old.split(".")[1:])).with_suffix(".py").exists(), f"{old} exists again"
