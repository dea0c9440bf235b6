"""Every tutorial's runnable commands run as written (docs/tutorials/*.md), so a tutorial cannot rot.

**The marker.** A fenced ``bash`` block whose opening fence follows a line holding exactly
``<!-- runnable -->`` (an HTML comment: the site does not show it) is runnable::

    <!-- runnable -->
    ```bash
    navbench make-level demo --seed 1 --size 5 --rooms 2
    ```

Every other block is shown, not run: the full-size runs (minutes to hours), and what needs a
cluster, a GPU or the reader's own files. Each tutorial gives at least one runnable block: a
tiny variant (a 5 m level, a few tasks, a few fit steps) of what it teaches.

**How they run.** The runnable blocks of one tutorial run in the order of the page, as one bash
script under ``set -euo pipefail``, in a fresh scratch folder: what one block writes, exports or
changes directory to, the next one sees, as in the terminal of a reader who types them one after
the other. The environment is the test's own, with nothing added that the page does not show:
``PATH`` starts with this Python's ``bin`` folder (so ``navbench``, ``python``, ``pip`` and
``evo_ape`` are the test environment's), ``PYTHONPATH`` names this checkout (as for every
subprocess of the tests, scripts/_env.py), ``NAVBENCH_DB`` is removed (so the database is the
scratch folder's ``results/navbench.db``, navbench's default) and the rest is inherited
(``NUMBA_CACHE_DIR``, which ``make test`` sets). No command is rewritten or substituted: if a
tutorial needs a file, a profile or a variable, it shows the command that makes it.

Cost: the eight tutorials together take about 95 s of CPU time, 8 to 15 s each (measured
2026-11-27 on the 2-core reference machine, serially, under a load of 4 to 8 from other work:
192 s wall for all eight), so about a minute of wall time under ``make test``'s two workers on
an idle machine. Each has a generous time limit (``LIMIT_S``) so that a loaded machine does not
fail them; times are printed (``pytest -s``), never asserted.
"""

from __future__ import annotations

import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest

from scripts._env import pythonpath_first

ROOT = Path(__file__).resolve().parents[2]
TUTORIALS = ROOT / "docs" / "tutorials"
#: The tutorials of the documentation (HELPERS.md, mkdocs.yml's navigation).
NAMES = ("reproduce-the-paper", "own-estimator", "own-map", "own-rgbd-data", "image-goals",
         "localisation", "ray-cluster", "gpu", "compare", "render-sequence")
MARKER = "<!-- runnable -->"
LIMIT_S = 600   # per tutorial, a loaded machine included

_FENCE = re.compile(r"^(?P<indent> {0,3})(?P<fence>`{3,}|~{3,})(?P<info>[^\n`]*)$")


def runnable_blocks(markdown: str) -> list[str]:
    """The bodies of the fenced ``bash`` blocks whose fence follows a ``<!-- runnable -->`` line
    (blank lines between them allowed), in page order. A marker before anything else, or before
    a fence of another language, is an error: a marked block must not be skipped silently."""
    lines = markdown.splitlines()
    blocks, i = [], 0
    while i < len(lines):
        if lines[i].strip() != MARKER:
            i += 1
            continue
        j = i + 1
        while j < len(lines) and not lines[j].strip():
            j += 1
        m = _FENCE.match(lines[j]) if j < len(lines) else None
        if m is None:
            raise ValueError(f"line {i + 1}: {MARKER} is not followed by a fenced block")
        lang = m["info"].strip().split()[0] if m["info"].strip() else ""
        if lang != "bash":
            raise ValueError(f"line {j + 1}: a runnable block must be ```bash, got {lang or 'no language'!r}")
        fence, k, body = m["fence"], j + 1, []
        while k < len(lines) and not (lines[k].strip().startswith(fence[0] * len(fence))
                                      and set(lines[k].strip()) == {fence[0]}):
            body.append(lines[k][len(m["indent"]):] if lines[k].startswith(m["indent"]) else lines[k])
            k += 1
        if k == len(lines):
            raise ValueError(f"line {j + 1}: the runnable block is not closed")
        blocks.append("\n".join(body))
        i = k + 1
    return blocks


def test_marker_parsing():
    md = ("# T\n\n```bash\nnot run\n```\n\n<!-- runnable -->\n```bash\necho one\n```\n\n"
          "text\n\n<!-- runnable -->\n\n````bash title=\"x\"\necho two\n```\nstill two\n````\n")
    assert runnable_blocks(md) == ["echo one", 'echo two\n```\nstill two']
    with pytest.raises(ValueError, match="must be ```bash"):
        runnable_blocks("<!-- runnable -->\n```python\nprint(1)\n```\n")
    with pytest.raises(ValueError, match="not followed by a fenced block"):
        runnable_blocks("<!-- runnable -->\ntext\n")
    with pytest.raises(ValueError, match="not closed"):
        runnable_blocks("<!-- runnable -->\n```bash\necho\n")


def test_every_tutorial_has_runnable_commands():
    pages = sorted(p.stem for p in TUTORIALS.glob("*.md"))
    assert pages == sorted(NAMES), "a tutorial was added or removed: update NAMES and mkdocs.yml"
    for name in NAMES:
        blocks = runnable_blocks((TUTORIALS / f"{name}.md").read_text(encoding="utf-8"))
        assert blocks, name
        for block in blocks:
            # under pipefail, `cmd | head` fails whenever head exits before cmd has written all
            # (EPIPE): a tutorial that passes or fails by timing
            assert not re.search(r"\|\s*head\b", block), (name, block)


def tutorial_env() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("NAVBENCH_DB", None)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env["PYTHONPATH"] = pythonpath_first(ROOT)
    return env


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_tutorial_runs_as_written(name, tmp_path):
    blocks = runnable_blocks((TUTORIALS / f"{name}.md").read_text(encoding="utf-8"))
    script = "set -euo pipefail\n" + "\n".join(blocks) + "\n"
    (tmp_path / ".tutorial.sh").write_text(script)
    t0, cpu0 = time.monotonic(), _children_cpu()
    try:
        p = subprocess.run(["bash", str(tmp_path / ".tutorial.sh")], cwd=tmp_path, env=tutorial_env(),
                           capture_output=True, text=True, timeout=LIMIT_S, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired as e:
        pytest.fail(f"{name}: the runnable commands took more than {LIMIT_S} s\n{(e.stdout or '')[-3000:]}")
    took, cpu = time.monotonic() - t0, _children_cpu() - cpu0
    out = p.stdout + p.stderr
    assert p.returncode == 0, f"{name}: exit {p.returncode} after {took:.0f} s\n{out[-6000:]}"
    assert "Traceback" not in out, out[-6000:]
    print(f"{name}: {took:.1f} s wall, {cpu:.1f} s CPU")  # for the record (pytest -s), never asserted


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime
