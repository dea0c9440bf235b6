#!/usr/bin/env python3
"""Blind hostile-input probe of navbench (issue 34, second fresh probe, written by probe34
without reading navbench's tests or the earlier probes' results).

Each case runs navbench as a subprocess in its own scratch folder /tmp/probe2-case-NNNN (a copy
of a small project built once: house-1 levels, a tiny cached `navbench all` run, a 6-frame TUM
sequence, a views .npz, a map .npz, a task file), with a timeout, and is classified:

  OK              clear one-line error with exit != 0 for a user error, or correct success
  TRACEBACK       a Python traceback printed for something a user caused
  HANG            the timeout was hit
  CRASH           killed by a signal (segfault, abort) or exit code >= 128 other than 130
  DATA-LOSS       a sentinel or stored result lost or changed, duplicate rows, a run stuck 'running'
  INVALID-RESULT  a score stored from invalid input (NaN/inf, measured on nothing), rows stored
                  by a refused command
  WRONG-MESSAGE   an error that names the wrong thing or is not one line
  WRONG-EXIT      a refused input with exit 0, or a user error with an exit other than 2
  WRITE-OUTSIDE   a refused command left new files outside the outputs it names

Usage:  python probe.py [--only SUBSTR] [--jobs 2] [--list]
Output: /work/probe2/raw/results.jsonl (one object per case), raw/NNNN.out (stdout+stderr),
        findings are written by report.py / by hand to findings.md.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

WT = Path(os.environ.get("PROBE_WT", "/work/wt-probe34"))
VENV_BIN = "/work/main/.venv/bin"
BASE = Path("/tmp/probe2-base")
OUTDIR = Path("/work/probe2/raw")
TINY = ("--set tasks.count=2 --set views.count=60 --set views.eval_count=10 --set fit.steps=20 "
        "--set navigation.episode.max_steps=30 --workers 1")
TINY_ALL = f"navbench all --profile quick {TINY}"

SEVERITY = ["CRASH", "HANG", "DATA-LOSS", "INVALID-RESULT", "TRACEBACK", "WRONG-MESSAGE",
            "WRONG-EXIT", "WRITE-OUTSIDE", "OK"]

SENTINELS = ["SENTINEL-root.txt", "results/SENTINEL-results.txt",
             "results/mine/SENTINEL-mine.txt", "results/cache/fit-map/my-notes/SENTINEL.txt",
             "levels/SENTINEL-levels.txt", "seq/SENTINEL-seq.txt", "tasks/SENTINEL-tasks.txt",
             "outside/keep/SENTINEL-outside.txt"]


def base_env(d: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NAVBENCH", "NUMBA", "OMP",
                                                                     "MPL", "MKL"))}
    env.update(PYTHONPATH=str(WT), NUMBA_CACHE_DIR=str(WT / ".numba_cache"),
               PATH=f"{VENV_BIN}:{env.get('PATH', '/usr/bin:/bin')}", HOME=str(d / "home"),
               COLUMNS="120", PYTHONDONTWRITEBYTECODE="1")
    return env


def sh(cmd, cwd, env=None, timeout=600):
    return subprocess.run(cmd, shell=True, cwd=cwd, env=env or base_env(Path(cwd)),
                          capture_output=True, text=True, timeout=timeout)


def build_base():
    if (BASE / "BASE-OK").exists():
        return
    shutil.rmtree(BASE, ignore_errors=True)
    BASE.mkdir(parents=True)
    shutil.copytree(WT / "levels", BASE / "levels")
    env = base_env(BASE)
    for cmd in [TINY_ALL, "navbench render-sequence house-1 seq --frames 6 --noise mid",
                "navbench import-views seq --out views.npz",
                "cp results/cache/fit-map/*/map.npz map.npz",
                "navbench sample-tasks house-1 --count 3 --out tasks",
                "navbench render-sequence house-1 seq12 --frames 12 --noise mid"]:
        r = sh(cmd, BASE, env)
        if r.returncode:
            raise SystemExit(f"base: {cmd} failed:\n{r.stdout}\n{r.stderr}")
    (BASE / "BASE-OK").write_text("ok\n")


# --------------------------------------------------------------------------- snapshot/db


SKIP_PARTS = (".holds", "__pycache__", "home")


def snapshot(d: Path) -> dict:
    snap = {}
    for root, dirs, files in os.walk(d, followlinks=False):
        rel_root = os.path.relpath(root, d)
        if any(p in SKIP_PARTS for p in Path(rel_root).parts):
            continue
        for name in files + [x for x in dirs if os.path.islink(os.path.join(root, x))]:
            p = os.path.join(root, name)
            try:
                st = os.lstat(p)
            except OSError:
                continue
            snap[os.path.normpath(os.path.join(rel_root, name))] = (st.st_size, st.st_mtime_ns)
    return snap


def db_state(path: Path) -> dict | None:
    if not path.is_file():
        return None
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=5)
        out = {"counts": {}, "nonfinite": [], "running": [], "failed": [], "dups": 0}
        tables = [r[0] for r in con.execute("select name from sqlite_master where type='table'")]
        for t in tables:
            out["counts"][t] = con.execute(f'select count(*) from "{t}"').fetchone()[0]
            cols = con.execute(f'pragma table_info("{t}")').fetchall()
            for c in cols:
                if c[2].upper().startswith(("FLOAT", "REAL")):
                    n = con.execute(f'select count(*) from "{t}" where "{c[1]}" > 1e308 or '
                                    f'"{c[1]}" < -1e308').fetchone()[0]
                    if n:
                        out["nonfinite"].append(f"{t}.{c[1]}:{n}")
        if "runs" in tables:
            out["running"] = [r[0] for r in con.execute("select id from runs where status='running'")]
            out["failed"] = [r[0] for r in con.execute("select id from runs where status='failed'")]
        if "episodes" in tables:
            out["dups"] = con.execute("select count(*) - count(distinct cell_key || ':' || task_id "
                                      "|| ':' || seed) from episodes").fetchone()[0]
        if "maps" in tables:
            for mk, mae, metrics in con.execute("select map_key, depth_mae_m, metrics from maps"):
                try:
                    m = json.loads(metrics)
                except Exception:
                    m = {}
                txt = json.dumps(m)
                if "NaN" in txt or "Infinity" in txt:
                    out["nonfinite"].append(f"maps.metrics {mk[:8]}")
                cov = m.get("coverage", m.get("depth_coverage"))
                if cov == 0 or (mae == 0.0):
                    out["nonfinite"].append(f"maps {mk[:8]} mae={mae} coverage={cov}")
        con.close()
        return out
    except sqlite3.DatabaseError as exc:
        return {"error": str(exc)}


# --------------------------------------------------------------------------- cases


class Case:
    def __init__(self, cls, name, cmd, expect="error", setup=None, env=None, timeout=60,
                 check=None, names=None, allow_remove=(), allow_new=(), runner=None,
                 copy_base=True, db="results/navbench.db", outputs=()):
        self.cls, self.name, self.cmd, self.expect = cls, name, cmd, expect
        self.setup, self.env, self.timeout, self.check = setup, env or {}, timeout, check
        self.names, self.allow_remove, self.allow_new = names, tuple(allow_remove), tuple(allow_new)
        self.runner, self.copy_base, self.db, self.outputs = runner, copy_base, db, tuple(outputs)


CASES: list[Case] = []


def case(*a, **k):
    CASES.append(Case(*a, **k))


def wfile(rel, data):
    """setup helper: write bytes/str to rel."""
    def f(d: Path):
        p = d / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        if p.is_symlink() or p.exists():
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()
        if isinstance(data, bytes):
            p.write_bytes(data)
        else:
            p.write_text(data)
    return f


def chain(*fs):
    def f(d):
        for g in fs:
            g(d)
    return f


def shell_setup(script):
    def f(d: Path):
        r = subprocess.run(script, shell=True, cwd=d, capture_output=True, text=True)
        if r.returncode:
            raise RuntimeError(f"setup failed: {script}: {r.stderr}")
    return f


def nonregular(rel, kind):
    """rel becomes: dir, fifo, devzero, loop (symlink loop), dangling, unreadable."""
    def f(d: Path):
        p = d / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        if p.is_symlink() or p.is_file():
            p.unlink()
        elif p.is_dir():
            shutil.rmtree(p)
        if kind == "dir":
            p.mkdir()
            (p / "x").write_text("x")
        elif kind == "fifo":
            os.mkfifo(p)
        elif kind == "devzero":
            p.symlink_to("/dev/zero")
        elif kind == "devurandom":
            p.symlink_to("/dev/urandom")
        elif kind == "loop":
            q = p.with_name(p.name + ".loop2")
            p.symlink_to(q.name)
            q.symlink_to(p.name)
        elif kind == "dangling":
            p.symlink_to("/nonexistent/probe2/target")
        elif kind == "unreadable":
            p.write_text("x")
            p.chmod(0)
    return f


DEEP_JSON = "[" * 5000 + "]" * 5000
DEEP_JSON_OBJ = '{"a":' * 3000 + "1" + "}" * 3000
NONUTF8 = b"\xff\xfe\xfa\x80\x81 not utf8 \xc3\x28"
BINARY = bytes(range(256)) * 40


def level_json(**over):
    d = json.loads((WT / "levels" / "house-1.json").read_text())
    d["name"] = "bad"
    for k, v in over.items():
        if v is DEL:
            d.pop(k, None)
        else:
            d[k] = v
    return d


class _Del:
    pass


DEL = _Del()


def level_case(name, doc_or_text, expect="error", cmds=None, raw=False, timeout=60):
    """A broken level file levels/bad.json read by several commands."""
    if raw:
        data = doc_or_text
    else:
        data = json.dumps(doc_or_text, allow_nan=True) if not isinstance(doc_or_text, str) \
            else doc_or_text
    for c in cmds or ["show-level bad --out out.png", "sample-tasks levels/bad.json --count 2 --out t2"]:
        case("level-json", f"{name} :: {c.split()[0]}", f"navbench {c}", expect=expect,
             setup=wfile("levels/bad.json", data), names=["bad"], timeout=timeout,
             allow_new=("out.png", "t2", "results/levels"))


def gen_cases():
    # ---------------------------------------------------------------- usage / unknown names
    usage = [
        ("no command", "navbench"),
        ("unknown command", "navbench frobnicate"),
        ("unknown option", "navbench all --frob"),
        ("unknown profile", "navbench all --profile quik"),
        ("profile empty name", "navbench all --profile ''"),
        ("profile path traversal", "navbench all --profile ../../../etc/passwd"),
        ("unknown level collect", "navbench collect-views housee-1 --count 5"),
        ("unknown level run-nav", f"navbench run-navigation housee-1 {TINY}"),
        ("level name with slash", "navbench sample-tasks ../house-1 --count 2"),
        ("level name empty", "navbench sample-tasks '' --count 2"),
        ("unknown estimator", f"navbench run-navigation house-1 --estimators ourz {TINY}"),
        ("empty estimator list", f"navbench run-navigation house-1 --estimators , {TINY}"),
        ("duplicate estimator", f"navbench run-navigation house-1 --estimators dynamics,dynamics {TINY}"),
        ("unknown noise", f"navbench run-navigation house-1 --noise medium {TINY}"),
        ("unknown camera collect", "navbench collect-views house-1 --camera full --count 5"),
        ("unknown camera render", "navbench render-sequence house-1 s2 --camera huge --frames 3"),
        ("unknown map", f"navbench run-navigation house-1 --map fitt {TINY}"),
        ("unknown goal", f"navbench run-navigation house-1 --goal picture {TINY}"),
        ("unknown online-ablation", f"navbench run-navigation house-1 --map online --online-ablation foo {TINY}"),
        ("online-ablation without online map", f"navbench run-navigation house-1 --online-ablation no-goal {TINY}"),
        ("unknown executor", f"navbench run-navigation house-1 --executor dask {TINY}"),
        ("address without ray", f"navbench run-navigation house-1 --address 1.2.3.4:6379 {TINY}"),
        ("ray unreachable address", f"navbench run-navigation house-1 --executor ray --address 127.0.0.1:1 {TINY}"),
        ("unknown condition name", f"navbench all --condition frob=1 {TINY}"),
        ("unknown condition value", f"navbench all --condition pose_quantisation=floor {TINY}"),
        ("condition without =", f"navbench all --condition pose_quantisation {TINY}"),
        ("unknown preset score", "navbench score --preset olympic"),
        ("unknown format score", "navbench score --format xml"),
        ("score run garbage", "navbench score --run abc"),
        ("score run negative", "navbench score --run -5"),
        ("score run 0", "navbench score --run 0"),
        ("score run huge", "navbench score --run 99999999999999999999999"),
        ("score run missing id", "navbench score --run 999"),
        ("score run list with junk", "navbench score --run 1,,x"),
        ("score unknown level", "navbench score --level nowhere"),
        ("score unknown benchmark version", "navbench score --benchmark-version 99"),
        ("report unknown preset", "navbench report --preset nope --out rep2"),
        ("report run missing", "navbench report --run 77 --out rep2"),
        ("report pair malformed", "navbench report --pair ours --out rep2"),
        ("report pair unknown", "navbench report --pair ours:frob --out rep2"),
        ("compare pair malformed", "navbench compare --pair ours-no-map"),
        ("compare pair three", "navbench compare --pair a:b:c"),
        ("compare unknown estimator", "navbench compare --pair ours:nope"),
        ("compare a garbage", "navbench compare --a x --b 1 --pair ours:ours"),
        ("compare b-db garbage url", "navbench compare --b-db mysql+nope://x --pair ours:ours"),
        ("compare interval bogus", "navbench compare --interval t"),
        ("export-trajectories bad source", "navbench export-trajectories ex --source both"),
        ("export-trajectories unknown run", "navbench export-trajectories ex --run 55"),
        ("export-trajectories unknown level", "navbench export-trajectories ex --level nope"),
        ("cache ls unknown stage", "navbench cache ls --stage fitmap"),
        ("cache unknown sub", "navbench cache purge"),
        ("db unknown sub", "navbench db drop"),
        ("make-level unknown kind", "navbench make-level lv --seed 1 --kind castle"),
        ("make-level no seed", "navbench make-level lv"),
        ("make-level bad name", "navbench make-level '../evil' --seed 1"),
        ("make-level name with space", "navbench make-level 'a b' --seed 1"),
        ("make-level existing name differs", "navbench make-level house-1 --seed 5"),
        ("make-level changed-from unknown", "navbench make-level ch --changed-from nope --changes 2 --seed 1"),
        ("localize unknown sampling", "navbench localize-eval house-1 --map map.npz --sampling spiral --queries 2 --no-store"),
        ("localize unknown changes", "navbench localize-eval house-1 --map map.npz --changes OC9 --queries 2 --no-store"),
        ("track-eval unknown odometry", "navbench track-eval house-1 --map map.npz --odometry gps --trajectories 1 --steps 3 --no-store"),
        ("track-eval unknown collisions", "navbench track-eval house-1 --map map.npz --collisions bounce --trajectories 1 --steps 3 --no-store"),
        ("track-eval unknown estimator", "navbench track-eval house-1 --map map.npz --estimators frob --trajectories 1 --steps 3 --no-store"),
        ("track-eval unknown noise", "navbench track-eval house-1 --map map.npz --noise extreme --trajectories 1 --steps 3 --no-store"),
        ("track-sequence unknown estimator", "navbench track-sequence seq --map map.npz --estimator gt2 --no-store"),
        ("track-sequence odometry gt+bogus", "navbench track-sequence seq --map map.npz --odometry gt+huge --no-store"),
        ("render-sequence unknown walk", "navbench render-sequence house-1 s2 --walk fly --frames 3"),
        ("render-sequence unknown noise", "navbench render-sequence house-1 s2 --noise loud --frames 3"),
        ("fit-map unknown device", "navbench fit-map house-1 --device tpu --steps 2"),
        ("fit-map cuda without gpu", f"navbench fit-map house-1 --device cuda {TINY.replace('--workers 1', '')}"),
        ("fit-map no level no views", "navbench fit-map --steps 2"),
        ("fit-map views auto without level", "navbench fit-map --views auto --steps 2"),
        ("fit-map short key", "navbench fit-map --views abc --steps 2"),
        ("fit-map unknown hex key", "navbench fit-map --views abcdef012345 --steps 2"),
        ("export-views unknown key", "navbench export-views deadbeef00 exv"),
        ("import-views out other suffix", "navbench import-views seq --out v.zip"),
        ("import-views neither out nor store", "navbench import-views seq"),
        ("import-views out exists", "navbench import-views seq --out views.npz"),
        ("bench unknown level", "navbench bench --quick --level nope --no-store --e2e-tasks 0 --repeats 1"),
        ("level-difficulty unknown", "navbench level-difficulty nope"),
        ("show-level unknown", "navbench show-level nope"),
        ("--version with junk", "navbench --version --frob"),
    ]
    for name, cmd in usage:
        case("usage/unknown-name", name, cmd, allow_new=("rep2", "ex", "exv", "s2", "lv", "ch"))

    # ---------------------------------------------------------------- --set values
    sets = [
        "taks.count=3", "tasks.count=", "tasks.count", "=3", "tasks.count=0", "tasks.count=-1",
        "tasks.count=3.5", "tasks.count=nan", "tasks.count=1e400", "tasks.count=99999999999999999999999",
        "tasks.count=true", "tasks.count=[1,2]", "fit.steps=fifty", "fit.steps=0",
        "fit.steps=1e100", "fit.lr=nan", "fit.lr=inf", "fit.lr=-inf", "fit.lr=1e308", "fit.lr=1e30",
        "fit.lr=0", "fit.lr=-0.1", "fit.lr=1e-400", "fit.nope=1", "fit.grid_shape=[1,1,1]",
        "fit.grid_shape=[100000,100000,100000]", "fit.grid_shape=[-5,2,2]", "fit.grid_shape=abc",
        "fit.max_range=0", "fit.max_range=-1", "fit.max_range=1e-9", "fit.n_samples=0",
        "fit.n_samples=100000000", "fit.pixels_per_image=0", "fit.images_per_batch=100000000",
        "fit.tau=2", "fit.tau=nan", "fit.sigma2_init=0", "fit.threads=0", "fit.threads=100000",
        "fit.optimizer=sgd9", "fit.device=quantum", "fit.init=random9",
        "views.count=0", "views.count=1", "views.camera=ultra", "views.seed=-1",
        "views.eval_seed=0", "views.eval_count=0", "levels=", "levels=nope",
        "levels=../../etc/passwd", "levels=house-1,,house-2", "level_seed=-3",
        "navigation.estimators=", "navigation.estimators=frob", "navigation.noise=loud",
        "navigation.seeds=0", "navigation.workers=-1", "navigation.episode.max_steps=0",
        "navigation.episode.max_steps=-5", "navigation.episode.max_steps=1e12",
        "navigation.episode.planner.step=1e-9", "navigation.episode.planner.step=0",
        "navigation.episode.planner.step=nan", "navigation.episode.planner.step=1e9",
        "navigation.episode.frob=1", "navigation.options.ours.optimizer=nope",
        "navigation.options.ours.frob=1", "navigation.options.frob.x=1",
        "conditions.pose_quantisation=ceil", "conditions.frob=1", "scoring.preset=olympic",
        "name=../../evil", "name=", "description=" + "x" * 100000, "tasks.seed=-1",
        "tasks.difficulty=impossible", "fit.lr=" + "[" * 3000 + "]" * 3000,
        "levels=" + "[" * 3000 + "]" * 3000, "fit.steps=" + "9" * 5000,
        "fit.lr=0x10", "fit.lr=1_0", "fit.lr='0.1'", "tasks.count=\x00",
    ]
    for s in sets:
        case("--set values", f"--set {s[:60]}", f"navbench all --profile quick {TINY} --set {sh_quote(s)}",
             names=["--set", s.split("=")[0][:20]] if "=" in s else ["--set"])

    # ---------------------------------------------------------------- -o values
    opts = [
        ("run-navigation", "ours.frob=1"), ("run-navigation", "frob=1"),
        ("run-navigation", "ours.optimizer=sgd9"), ("run-navigation", "ours.prior_sigma=NaN"),
        ("run-navigation", "ours.prior_sigma=[NaN,1]"), ("run-navigation", "ours.prior_sigma=Infinity"),
        ("run-navigation", "ours.prior_sigma=" + "[" * 5000 + "]" * 5000),
        ("run-navigation", "ours.prior_sigma=1e400"), ("run-navigation", "ours.prior_sigma=-1"),
        ("run-navigation", "ours.steps=" + "9" * 5000), ("run-navigation", "ours.steps=-3"),
        ("run-navigation", "ours.steps=1e18"), ("run-navigation", "dynamics.x=1"),
        ("run-navigation", "gt.foo=1"), ("run-navigation", "no-map.optimizer=adam"),
        ("run-navigation", "ours.=1"), ("run-navigation", ".x=1"), ("run-navigation", "ours.optimizer"),
        ("run-navigation", 'ours.prior_sigma={"a":' * 3000 + "1" + "}" * 3000),
        ("track-eval", "ours.frob=1"), ("track-eval", "ours.optimizer=nope"),
        ("track-eval", "ours.prior_sigma=NaN"), ("track-eval", "emission.steps=-1"),
        ("track-eval", "emission.steps=99999999999999999999999"),
        ("track-eval", "ours.lr=1e300"), ("track-eval", "ours." + "x" * 10000 + "=1"),
        ("localize-eval", "min_candidates=-1"), ("localize-eval", "frob=1"),
        ("localize-eval", "row_step=1e-9"), ("localize-eval", "row_step=nan"),
        ("localize-eval", "min_candidates=1e400"), ("localize-eval", "min_candidates=" + "[" * 5000),
        ("localize-eval", "row_top=-1e300"), ("localize-eval", "=3"),
        ("track-sequence", "frob=1"), ("track-sequence", "optimizer=nope"),
        ("track-sequence", "prior_sigma=NaN"), ("track-sequence", "ours.optimizer=adam"),
        ("track-sequence", "steps=" + "[" * 5000 + "]" * 5000), ("track-sequence", "lr=-1e300"),
    ]
    for cmdname, o in opts:
        base = {"run-navigation": f"navbench run-navigation house-1 {TINY} --estimators ours,dynamics",
                "track-eval": "navbench track-eval house-1 --map map.npz --trajectories 1 --steps 3 --estimators ours,emission --no-store",
                "localize-eval": "navbench localize-eval house-1 --map map.npz --queries 2 --no-store",
                "track-sequence": "navbench track-sequence seq --map map.npz --no-store --out est.txt"}[cmdname]
        case("-o values", f"{cmdname} -o {o[:50]}", f"{base} -o {sh_quote(o)}", names=["-o", "option", o.split("=")[0][:15]])

    # ---------------------------------------------------------------- profile TOML
    q = (WT / "navbench/profiles/quick.toml").read_text()
    toml_bad = [
        ("malformed", "name = \"x\"\n[fit\nsteps=3\n"),
        ("empty", ""),
        ("binary", BINARY),
        ("not utf8", NONUTF8),
        ("only comment", "# nothing\n"),
        ("unknown key", q + "\nfrobnicate = 1\n"),
        ("unknown table key", q.replace("[fit]", "[fit]\nfrob = 3")),
        ("wrong type levels", q.replace('levels = ["house-1"]', "levels = 3")),
        ("levels empty", q.replace('levels = ["house-1"]', "levels = []")),
        ("levels nested", q.replace('levels = ["house-1"]', 'levels = [["house-1"]]')),
        ("nan steps", q.replace("steps = 2000", "steps = nan")),
        ("inf lr", q.replace("steps = 2000", "steps = 2000\nlr = inf")),
        ("neg nan lr", q.replace("steps = 2000", "steps = 2000\nlr = -nan")),
        ("huge int", q.replace("count = 30", "count = 9223372036854775807")),
        ("too big int", q.replace("count = 30", "count = 99999999999999999999999999")),
        ("lr 1e308", q.replace("steps = 2000", "steps = 20\nlr = 1e308")),
        ("negative seed", q.replace("seed = 0                  # batch", "seed = -7 #")),
        ("deep array", "name='d'\nlevels = " + "[" * 3000 + "]" * 3000 + "\n"),
        ("deep inline table", "name='d'\nx = " + "{a=" * 2000 + "1" + "}" * 2000 + "\n"),
        ("huge file", "# " + "x" * (70 * 1024 * 1024) + "\n"),
        ("many keys", "name='x'\n" + "".join(f"k{i} = {i}\n" for i in range(200000))),
        ("extends unknown", 'extends = "quik"\n[tasks]\ncount = 2\n'),
        ("extends self", 'extends = "p.toml"\n'),
        ("extends missing file", 'extends = "nope/x.toml"\n'),
        ("extends dir", 'extends = "sub"\n'),
        ("extends /dev/zero", 'extends = "/dev/zero"\n'),
        ("extends fifo", 'extends = "fifo.toml"\n'),
        ("extends number", "extends = 3\n"),
        ("extends list", 'extends = ["quick"]\n'),
        ("extends traversal", 'extends = "../../../../../etc/passwd"\n'),
        ("name with slash", q.replace('name = "quick"', 'name = "../evil"')),
        ("name very long", q.replace('name = "quick"', 'name = "' + "n" * 5000 + '"')),
        ("scoring preset bad", q + '\n[scoring]\npreset = "olympic"\n'),
        ("conditions bad", q + '\n[conditions]\npose_quantisation = "ceil"\n'),
        ("fit device bad", q.replace("[fit]", '[fit]\ndevice = "tpu"')),
        ("views eval seed equal", q.replace("eval_seed = 1", "eval_seed = 0")),
        ("navigation table is string", q.replace("[navigation]", "navigation2 = 1\n[navigation]")
         + '\nnavigation = "x"\n'),
        ("duplicate key", q + '\nname = "again"\n'),
        ("planner step tiny", q + "\n[navigation.episode.planner]\nstep = 1e-9\n"),
        ("estimators unknown", q.replace('estimators = ["ours", "no-map", "dynamics"]', 'estimators = ["frob"]')),
    ]
    for name, text in toml_bad:
        setup = wfile("p.toml", text)
        if name == "extends dir":
            setup = chain(setup, nonregular("sub", "dir"))
        if name == "extends fifo":
            setup = chain(setup, nonregular("fifo.toml", "fifo"))
        case("profile TOML", name, f"navbench all --profile p.toml --workers 1 --set views.count=60 --set fit.steps=20 --set views.eval_count=10",
             setup=setup, names=["p.toml", "p"], timeout=90)
    # the same file through other commands
    for name, text in [("malformed", "[fit\n"), ("deep", "x=" + "[" * 3000 + "]" * 3000), ("binary", BINARY)]:
        for c in ["fit-map house-1 --profile p.toml --steps 2", "collect-views house-1 --profile p.toml --count 5",
                  "track-eval house-1 --profile p.toml --trajectories 1 --steps 2 --no-store",
                  "localize-eval house-1 --profile p.toml --queries 2 --no-store"]:
            case("profile TOML", f"{name} via {c.split()[0]}", f"navbench {c}", setup=wfile("p.toml", text), names=["p.toml"])
    for kind in ["dir", "fifo", "devzero", "loop", "dangling", "unreadable"]:
        case("non-regular path", f"profile is {kind}", "navbench all --profile p.toml", setup=nonregular("p.toml", kind),
             names=["p.toml"], timeout=30)

    # ---------------------------------------------------------------- level JSON
    L = level_json
    wall = {"a": [1.0, 1.0], "b": [2.0, 2.0], "thickness": 0.1, "texture": 0}
    level_case("malformed", "{\"name\": ", raw=True)
    level_case("empty", "", raw=True)
    level_case("binary", BINARY, raw=True)
    level_case("not utf8", NONUTF8, raw=True)
    level_case("json list", "[]", raw=True)
    level_case("json null", "null", raw=True)
    level_case("deep", DEEP_JSON, raw=True)
    level_case("deep object", DEEP_JSON_OBJ, raw=True)
    level_case("deep meta", json.dumps(L()).replace('"meta": {', '"meta": {"deep": ' + DEEP_JSON + ", ", 1), raw=True)
    level_case("schema 2", L(schema_version=2))
    level_case("schema string", L(schema_version="1"))
    level_case("name mismatch", dict(L(), name="other"))
    level_case("width 0", L(width=0))
    level_case("width negative", L(width=-3))
    level_case("width 1e9", L(width=1e9))
    level_case("width NaN", json.dumps(L()).replace('"width": 11.4', '"width": NaN'), raw=True)
    level_case("width Infinity", json.dumps(L()).replace('"width": 11.4', '"width": Infinity'), raw=True)
    level_case("width 1e400", json.dumps(L()).replace('"width": 11.4', '"width": 1e400'), raw=True)
    level_case("width 5000 digits", json.dumps(L()).replace('"width": 11.4', '"width": ' + "1" * 5000), raw=True)
    level_case("width string", L(width="11"))
    level_case("width bool", L(width=True))
    level_case("height 0", L(height=0))
    level_case("height 1e6", L(height=1e6))
    level_case("no walls no obstacles", L(walls=[], obstacles=[]))
    level_case("walls missing", L(walls=DEL))
    level_case("walls not list", L(walls={"a": 1}))
    level_case("wall outside box", L(walls=[dict(wall, b=[500.0, 2.0])]))
    level_case("wall NaN point", json.dumps(L(walls=[dict(wall, a=[1.0, 1.5])])).replace("1.5", "NaN"), raw=True)
    level_case("wall thickness 0", L(walls=[dict(wall, thickness=0)]))
    level_case("wall thickness 5", L(walls=[dict(wall, thickness=5)]))
    level_case("wall texture out of range", L(walls=[dict(wall, texture=999)]))
    level_case("wall texture negative", L(walls=[dict(wall, texture=-1)]))
    level_case("wall degenerate", L(walls=[dict(wall, b=[1.0, 1.0])]), expect="either")
    level_case("wall point 3d", L(walls=[dict(wall, a=[1.0, 1.0, 1.0])]))
    level_case("100k walls", L(walls=[dict(wall)] * 100000), timeout=60)
    level_case("3000 walls", L(walls=[{"a": [0.1 + i * 0.003, 0.5], "b": [0.1 + i * 0.003, 0.6], "thickness": 0.01, "texture": 0} for i in range(3000)]), timeout=60)
    poly_big = [[5 + 2 * __import__("math").cos(t / 20000 * 6.283), 5 + 2 * __import__("math").sin(t / 20000 * 6.283)] for t in range(20000)]
    level_case("obstacle 20000 vertices", L(obstacles=[{"polygon": poly_big, "height": 0.5, "texture": 0}]), timeout=60)
    level_case("obstacle non-convex", L(obstacles=[{"polygon": [[3, 3], [5, 3], [4, 4], [5, 5], [3, 5]], "height": 0.5, "texture": 0}]))
    level_case("obstacle 2 points", L(obstacles=[{"polygon": [[3, 3], [5, 3]], "height": 0.5, "texture": 0}]))
    level_case("obstacle height above", L(obstacles=[{"polygon": [[3, 3], [5, 3], [4, 5]], "height": 50, "texture": 0}]))
    level_case("obstacle height negative", L(obstacles=[{"polygon": [[3, 3], [5, 3], [4, 5]], "height": -1, "texture": 0}]))
    level_case("obstacle self-crossing", L(obstacles=[{"polygon": [[3, 3], [5, 5], [5, 3], [3, 5]], "height": 0.5, "texture": 0}]))
    level_case("textures empty", L(textures=[]))
    level_case("texture kind bogus", L(textures=[{"kind": "plaid", "base": [0.5] * 3, "amp": [0.1] * 3, "waves": []}] * 20))
    level_case("texture base 2 values", L(textures=[{"kind": "tiles", "base": [0.5, 0.5], "amp": [0.1] * 3, "waves": [[1, 1, 1], [1, 1, 1]]}] * 20))
    level_case("floor_texture out of range", L(floor_texture=500))
    level_case("floor_texture float", L(floor_texture=0.5))
    level_case("disconnected free space", L(walls=L()["walls"] + [{"a": [5.7, 0.0], "b": [5.7, 11.2], "thickness": 0.3, "texture": 0}]))
    level_case("file too big", '{"name": "bad", "pad": "' + "x" * (9 * 1024 * 1024) + '"}', raw=True)
    level_case("bom prefix", "\ufeff" + json.dumps(L()), raw=True, expect="either")
    for kind in ["dir", "fifo", "devzero", "loop", "dangling"]:
        for c in ["show-level levels/bad.json --out o.png", "sample-tasks levels/bad.json --count 2 --out t2",
                  f"run-navigation levels/bad.json {TINY}"]:
            case("non-regular path", f"level file is {kind} :: {c.split()[0]}", f"navbench {c}",
                 setup=nonregular("levels/bad.json", kind), names=["bad"], timeout=30, allow_new=("t2",))
    # the committed house-1 level itself corrupted, then the cached run reruns
    for name, text in [("truncated", (WT / "levels/house-1.json").read_text()[:500]), ("deep", DEEP_JSON),
                       ("NaN width", (WT / "levels/house-1.json").read_text().replace('"width": 11.4', '"width": NaN'))]:
        case("level-json", f"house-1.json {name} then all", TINY_ALL, setup=wfile("levels/house-1.json", text),
             names=["house-1"])

    # ---------------------------------------------------------------- task files
    tfile = "tasks/house-1-3-ba575560.json"
    tdoc = json.loads((BASE / tfile).read_text()) if (BASE / tfile).exists() else None

    def tcase(name, text, expect="error"):
        for c in ["level-difficulty house-1", f"run-navigation house-1 {TINY} --estimators dynamics"]:
            case("task file", f"{name} :: {c.split()[0]}", f"navbench {c}", setup=wfile(tfile, text),
                 names=["house-1-3-ba575560.json", "tasks/"], expect=expect)
    if tdoc:
        def T(**kw):
            d = json.loads(json.dumps(tdoc))
            for k, v in kw.items():
                if v is DEL:
                    d.pop(k)
                else:
                    d[k] = v
            return json.dumps(d)

        def TT(i, **kw):
            d = json.loads(json.dumps(tdoc))
            d["tasks"][i].update(kw)
            return json.dumps(d, allow_nan=True)
        tcase("malformed", "{\"format\": ")
        tcase("empty", "")
        tcase("binary", BINARY)
        tcase("deep", DEEP_JSON)
        tcase("wrong format", T(format="other"))
        tcase("version 9", T(version=9))
        tcase("level mismatch", T(level="house-2"))
        tcase("level_sha wrong", T(level_sha256="0" * 64))
        tcase("count lies", T(count=200))
        tcase("tasks empty", T(tasks=[]))
        tcase("tasks not list", T(tasks="x"))
        tcase("start NaN", TT(0, start_x=float("nan")))
        tcase("start inside wall", TT(0, start_x=0.05, start_y=0.05))
        tcase("target outside level", TT(1, target_x=500.0))
        tcase("optimal length wrong", TT(1, optimal_length=0.5))
        tcase("optimal length negative", TT(1, optimal_length=-1.0))
        tcase("optimal length zero", TT(1, optimal_length=0.0))
        tcase("start heading inf", TT(0, start_heading=float("inf")))
        tcase("duplicate ids", TT(1, id=0))
        tcase("id string", TT(1, id="a"))
        tcase("task missing key", json.dumps({**tdoc, "tasks": [{k: v for k, v in t.items() if k != "target_y"} for t in tdoc["tasks"]]}))
        tcase("start == target", TT(0, target_x=tdoc["tasks"][0]["start_x"], target_y=tdoc["tasks"][0]["start_y"]))
    for kind in ["dir", "fifo", "devzero", "dangling", "loop"]:
        case("non-regular path", f"task file is {kind}", "navbench level-difficulty house-1",
             setup=nonregular(tfile, kind), names=["house-1-3", "tasks"], timeout=30)
    case("non-regular path", "tasks/ is a file", f"navbench run-navigation house-1 {TINY} --estimators dynamics",
         setup=chain(shell_setup("rm -rf tasks"), wfile("tasks", "x")), expect="either")
    case("non-regular path", "sample-tasks --out is a file", "navbench sample-tasks house-1 --count 2 --out f",
         setup=wfile("f", "keep"), names=["f"])
    case("non-regular path", "sample-tasks --out /dev/full", "navbench sample-tasks house-1 --count 2 --out /dev/full", names=["/dev/full"])

    # ---------------------------------------------------------------- views / map npz
    import numpy as np  # noqa: E402

    def npz_setup(rel, mutate, src="views.npz"):
        def f(d: Path):
            z = dict(np.load(BASE / src, allow_pickle=False))
            z = mutate(z)
            p = d / rel
            if isinstance(z, (bytes, str)):
                p.write_bytes(z if isinstance(z, bytes) else z.encode())
            else:
                with open(p, "wb") as fh:
                    np.savez(fh, **z)
        return f

    def hdr(mod):
        def m(z):
            h = json.loads(str(z["header"]))
            mod(h)
            z["header"] = np.array(json.dumps(h, allow_nan=True))
            return z
        return m

    def setk(k, v):
        def m(z):
            z[k] = v(z) if callable(v) else v
            return z
        return m

    def delk(k):
        def m(z):
            z.pop(k)
            return z
        return m

    trunc = lambda z: (BASE / "views.npz").read_bytes()[:3000]  # noqa: E731
    views_bad = [
        ("not a zip", lambda z: b"hello, not a zip"),
        ("truncated", trunc),
        ("empty file", lambda z: b""),
        ("missing rgb", delk("rgb")), ("missing header", delk("header")),
        ("header not JSON", setk("header", np.array("{nope"))),
        ("header deep", setk("header", np.array(DEEP_JSON))),
        ("header count lies", hdr(lambda h: h.update(count=1000))),
        ("header format 9", hdr(lambda h: h.update(format_version=9))),
        ("intrinsics fx 0", hdr(lambda h: h["intrinsics"].update(fx=0))),
        ("intrinsics fx NaN", hdr(lambda h: h["intrinsics"].update(fx=float("nan")))),
        ("intrinsics fx bool", hdr(lambda h: h["intrinsics"].update(fx=True))),
        ("intrinsics width huge", hdr(lambda h: h["intrinsics"].update(width=10 ** 9))),
        ("box inverted", hdr(lambda h: h.update(box=[[11.4, 11.2, 1.2], [0, 0, 0]]))),
        ("box NaN", hdr(lambda h: h.update(box=[[float("nan"), 0, 0], [11.4, 11.2, 1.2]]))),
        ("box huge", hdr(lambda h: h.update(box=[[-1e6, -1e6, 0], [1e6, 1e6, 1.2]]))),
        ("poses NaN", setk("poses", lambda z: np.where(np.arange(18).reshape(6, 3) == 4, np.nan, z["poses"]))),
        ("poses inf", setk("poses", lambda z: z["poses"] * np.inf)),
        ("poses wrong shape", setk("poses", lambda z: z["poses"][:, :2])),
        ("poses fewer than images", setk("poses", lambda z: z["poses"][:3])),
        ("rgb float", setk("rgb", lambda z: z["rgb"].astype(np.float64))),
        ("rgb wrong size", setk("rgb", lambda z: z["rgb"][:, :60])),
        ("depth NaN", setk("depth", lambda z: np.full_like(z["depth"], np.nan))),
        ("depth negative", setk("depth", lambda z: -z["depth"])),
        ("depth all invalid", setk("valid", lambda z: np.zeros_like(z["valid"]))),
        ("valid int", setk("valid", lambda z: z["valid"].astype(np.int64))),
        ("object array pickle", setk("poses", lambda z: np.array([object()] * 6, dtype=object))),
        ("zero views", lambda z: {k: (v[:0] if v.ndim else np.array(json.dumps({**json.loads(str(v)), "count": 0}))) for k, v in z.items()}),
    ]
    for name, mut in views_bad:
        for c in ["fit-map --views bad.npz --steps 2 --heldout-every 2", "export-views bad.npz exv"]:
            case("views npz", f"{name} :: {c.split()[0]}", f"navbench {c}", setup=npz_setup("bad.npz", mut),
                 names=["bad.npz"], allow_new=("exv",), timeout=90)
    case("invalid-result", "fit-map --views X --heldout X", "navbench fit-map --views views.npz --heldout views.npz --steps 2 --json",
         names=["heldout", "views.npz"], timeout=120)
    case("invalid-result", "fit-map on all-invalid depth", "navbench fit-map --views bad.npz --steps 2 --heldout-every 2 --json",
         setup=npz_setup("bad.npz", setk("valid", lambda z: np.zeros_like(z["valid"]))), names=["bad.npz", "valid", "depth"], timeout=120)
    case("invalid-result", "fit-map with max_range leaving nothing", f"navbench fit-map house-1 {TINY.replace('--workers 1', '')} --set fit.max_range=0.02 --json",
         names=["max_range"], timeout=120)
    case("invalid-result", "fit-map with lr 1e30", f"navbench fit-map house-1 {TINY.replace('--workers 1', '')} --set fit.lr=1e30 --json",
         names=["lr"], timeout=120)
    case("invalid-result", "fit-map with lr 9 (in range) diverging?", f"navbench fit-map house-1 {TINY.replace('--workers 1', '')} --set fit.lr=9 --json",
         expect="either", timeout=120)

    maps_bad = [
        ("not a zip", lambda z: b"PK\x03\x04garbage"),
        ("truncated", lambda z: (BASE / "map.npz").read_bytes()[:5000]),
        ("missing occ", delk("occ")), ("missing header", delk("header")),
        ("header deep", setk("header", np.array(DEEP_JSON))),
        ("header shape huge", hdr(lambda h: h["spec"].update(shape=[100000, 100000, 100000]))),
        ("header shape mismatch", hdr(lambda h: h["spec"].update(shape=[10, 10, 10]))),
        ("header lo > hi", hdr(lambda h: h["spec"].update(lo=[20, 20, 5]))),
        ("header lo NaN", hdr(lambda h: h["spec"].update(lo=[float("nan"), 0, 0]))),
        ("header tau 5", hdr(lambda h: h.update(tau=5))),
        ("header kind unknown plugin", hdr(lambda h: h.update(kind="neural-frob"))),
        ("header step 1e-9", hdr(lambda h: h["meta"].update(step=1e-9))),
        ("header max_range 0", hdr(lambda h: h["meta"].update(max_range=0))),
        ("occ NaN", setk("occ", lambda z: np.full_like(z["occ"], np.nan))),
        ("occ 1e30", setk("occ", lambda z: np.full_like(z["occ"], 1e30))),
        ("occ float64", setk("occ", lambda z: z["occ"].astype(np.float64))),
        ("occ 1 cell per axis", lambda z: {"occ": np.zeros((1, 1, 1), np.float32), "col": np.zeros((1, 1, 1, 3), np.float16),
                                          "header": np.array(json.dumps({**json.loads(str(z["header"])), "spec": {"lo": [0, 0, 0], "hi": [1, 1, 1], "shape": [1, 1, 1]}}))}),
        ("col wrong shape", setk("col", lambda z: z["col"][..., :2])),
        ("occ object", setk("occ", np.array([object()], dtype=object))),
    ]
    for name, mut in maps_bad:
        for c in ["track-sequence seq --map bad.npz --no-store --out est.txt",
                  f"run-navigation house-1 --map bad.npz {TINY} --estimators ours",
                  "localize-eval house-1 --map bad.npz --queries 2 --no-store"]:
            case("map npz", f"{name} :: {c.split()[0]}", f"navbench {c}", setup=npz_setup("bad.npz", mut, src="map.npz"),
                 names=["bad.npz"], timeout=90, allow_new=("results/sequences",))
    for kind in ["dir", "fifo", "devzero", "dangling", "loop"]:
        case("non-regular path", f"--map is {kind}", "navbench track-sequence seq --map bad.npz --no-store --out e.txt",
             setup=nonregular("bad.npz", kind), names=["bad.npz"], timeout=30)
        case("non-regular path", f"--views is {kind}", "navbench fit-map --views bad.npz --steps 2",
             setup=nonregular("bad.npz", kind), names=["bad.npz"], timeout=30)
        case("non-regular path", f"export-views src is {kind}", "navbench export-views bad.npz exv",
             setup=nonregular("bad.npz", kind), names=["bad.npz"], timeout=30)

    # ---------------------------------------------------------------- TUM / intrinsics
    intr = json.loads((BASE / "seq/intrinsics.json").read_text()) if (BASE / "seq/intrinsics.json").exists() else {}

    def tum(name, setup, cmds=("import-views seq --out v2.npz",),
            expect="error", names=("seq",)):
        for c in cmds:
            case("TUM / intrinsics", f"{name} :: {c.split()[0]}", f"navbench {c}", setup=setup, names=list(names),
                 expect=expect, allow_new=("v2.npz", "results/sequences"), timeout=60)

    def I(**kw):
        d = dict(intr)
        for k, v in kw.items():
            if v is DEL:
                d.pop(k, None)
            else:
                d[k] = v
        return json.dumps(d, allow_nan=True)
    for n, t in [("malformed", "{"), ("empty", ""), ("binary", BINARY), ("deep", DEEP_JSON),
                 ("list", "[1,2]"), ("fx bool", I(fx=True)), ("fx string", I(fx="75")), ("fx 0", I(fx=0)),
                 ("fx negative", I(fx=-75)), ("fx NaN", I(fx=float("nan"))), ("fx inf", I(fx=float("inf"))),
                 ("fx 1e308", I(fx=1e308)), ("width 0", I(width=0)), ("width huge", I(width=10 ** 8)),
                 ("width mismatch", I(width=320)), ("cx NaN", I(cx=float("nan"))), ("depth_scale 0", I(depth_scale=0)),
                 ("depth_scale negative", I(depth_scale=-5000)), ("camera_height NaN", I(camera_height=float("nan"))),
                 ("camera_height 1e300", I(camera_height=1e300)), ("box inverted", I(box=[[11.4, 11.2, 1.2], [0, 0, 0]])),
                 ("box 1e300", I(box=[[-1e300, -1e300, 0], [1e300, 1e300, 1.2]])), ("fx missing", I(fx=DEL)),
                 ("width 5000 digits", json.dumps(intr).replace('"width": 160', '"width": ' + "1" * 5000))]:
        tum(f"intrinsics {n}", wfile("seq/intrinsics.json", t), names=("intrinsics.json",),
            cmds=("import-views seq --out v2.npz", "track-sequence seq --map map.npz --no-store --out e.txt"))
    for kind in ["dir", "fifo", "devzero", "dangling"]:
        tum(f"intrinsics is {kind}", nonregular("seq/intrinsics.json", kind), names=("intrinsics.json",))
        tum(f"rgb.txt is {kind}", nonregular("seq/rgb.txt", kind), names=("rgb.txt",))
        tum(f"groundtruth.txt is {kind}", nonregular("seq/groundtruth.txt", kind), names=("groundtruth.txt",),
            cmds=("import-views seq --out v2.npz",))
        tum(f"a png is {kind}", nonregular("seq/rgb/0.050000.png", kind), names=("0.050000.png",), cmds=("import-views seq --out v2.npz",))
    rgbtxt = (BASE / "seq/rgb.txt").read_text() if (BASE / "seq/rgb.txt").exists() else ""
    gt = (BASE / "seq/groundtruth.txt").read_text() if (BASE / "seq/groundtruth.txt").exists() else ""
    lines = [ln for ln in gt.splitlines() if not ln.startswith("#")]
    for n, rel, t in [
        ("rgb.txt empty", "seq/rgb.txt", ""), ("rgb.txt garbage", "seq/rgb.txt", "hello world\nfoo\n"),
        ("rgb.txt binary", "seq/rgb.txt", BINARY), ("rgb.txt missing png", "seq/rgb.txt", rgbtxt.replace("rgb/0.100000.png", "rgb/nope.png")),
        ("rgb.txt path escape", "seq/rgb.txt", rgbtxt.replace("rgb/0.100000.png", "../../../../etc/passwd")),
        ("rgb.txt abs path", "seq/rgb.txt", rgbtxt.replace("rgb/0.100000.png", "/etc/hostname")),
        ("rgb.txt NaN timestamp", "seq/rgb.txt", rgbtxt.replace("0.100000 rgb", "nan rgb")),
        ("rgb.txt inf timestamp", "seq/rgb.txt", rgbtxt.replace("0.100000 rgb", "inf rgb")),
        ("rgb.txt huge line", "seq/rgb.txt", "0.0 " + "a" * 5_000_000 + "\n"),
        ("rgb.txt 1M lines", "seq/rgb.txt", "".join(f"{i*0.001:.6f} rgb/0.000000.png\n" for i in range(300000))),
        ("gt empty", "seq/groundtruth.txt", ""), ("gt 7 fields", "seq/groundtruth.txt", "\n".join(ln.rsplit(" ", 1)[0] for ln in lines)),
        ("gt NaN", "seq/groundtruth.txt", "\n".join(ln.replace(" 0.500000000 ", " nan ") for ln in lines)),
        ("gt zero quaternion", "seq/groundtruth.txt", "\n".join(" ".join(ln.split()[:4] + ["0", "0", "0", "0"]) for ln in lines)),
        ("gt non-unit quaternion", "seq/groundtruth.txt", "\n".join(" ".join(ln.split()[:4] + [str(float(x) * 7) for x in ln.split()[4:]]) for ln in lines)),
        ("gt tilted", "seq/groundtruth.txt", "\n".join(" ".join(ln.split()[:4] + ["0", "0", "0", "1"]) for ln in lines)),
        ("gt far timestamps", "seq/groundtruth.txt", "\n".join(f"{float(ln.split()[0]) + 1000:.6f} " + " ".join(ln.split()[1:]) for ln in lines)),
        ("gt 1e300 position", "seq/groundtruth.txt", "\n".join(ln.replace(" 0.500000000 ", " 1e300 ") for ln in lines)),
        ("gt duplicate timestamps", "seq/groundtruth.txt", "\n".join([lines[0]] * len(lines))),
        ("depth.txt missing", "seq/depth.txt", None),
    ]:
        setup = wfile(rel, t) if t is not None else shell_setup(f"rm -f {rel}")
        tum(n, setup, names=(Path(rel).name, "seq"))
    for n, data in [("rgb png garbage", b"\x89PNG\r\n\x1a\nxxxx"), ("rgb png empty", b""), ("rgb png is jpeg text", b"\xff\xd8\xff\xe0hello")]:
        tum(n, wfile("seq/rgb/0.050000.png", data), names=("0.050000.png", "png"))
    tum("rgb png wrong size", shell_setup("python3 -c \"import numpy as np; from PIL import Image; Image.fromarray(np.zeros((10,10,3),np.uint8)).save('seq/rgb/0.050000.png')\""),
        names=("0.050000.png",))
    tum("depth png 8-bit", shell_setup("python3 -c \"import numpy as np; from PIL import Image; Image.fromarray(np.zeros((120,160),np.uint8)).save('seq/depth/0.050000.png')\""),
        names=("0.050000.png", "depth"))
    tum("depth png rgb", shell_setup("cp seq/rgb/0.050000.png seq/depth/0.050000.png"), names=("0.050000.png", "depth"))
    tum("all depth zero", shell_setup("python3 -c \"import numpy as np,glob; from PIL import Image; [Image.fromarray(np.zeros((120,160),np.uint16)).save(p) for p in glob.glob('seq/depth/*.png')]\""),
        names=("depth", "valid", "seq"), cmds=("fit-map --views seq --steps 2 --heldout-every 2 --json",))
    for opt in ["--fx 0", "--fx -5", "--fx nan", "--fx inf", "--fx 1e308", "--fy nan", "--cx inf", "--cy -1e300",
                "--camera-height nan", "--camera-height -1", "--depth-scale 0", "--depth-scale nan", "--depth-scale -1",
                "--max-dt nan", "--max-dt -1", "--max-dt inf", "--max-tilt nan", "--max-tilt -1", "--max-tilt 1e300",
                "--max-height-dev nan", "--max-height-dev -3", "--fx abc", "--fx ''"]:
        for c in ["import-views seq --out v2.npz", "track-sequence seq --map map.npz --no-store --out e.txt"]:
            case("absurd numbers", f"{c.split()[0]} {opt}", f"navbench {c} {opt}", names=[opt.split()[0]],
                 allow_new=("v2.npz",))
    # odometry files for track-sequence
    odo = (BASE / "seq/odometry.txt").read_text() if (BASE / "seq/odometry.txt").exists() else ""
    for n, t in [("empty", ""), ("garbage", "a b c\n"), ("NaN", odo.replace(" 0.500000000 ", " nan ")),
                 ("6 fields", "\n".join(" ".join(ln.split()[:6]) for ln in odo.splitlines())),
                 ("binary", BINARY), ("one line", odo.splitlines()[0] + "\n"), ("inf", odo.replace(" 0.500000000 ", " inf "))]:
        case("TUM / intrinsics", f"odometry file {n}", "navbench track-sequence seq --map map.npz --odometry odo.txt --no-store --out e.txt",
             setup=wfile("odo.txt", t), names=["odo.txt"])
    for kind in ["dir", "fifo", "devzero", "dangling"]:
        case("non-regular path", f"odometry file is {kind}", "navbench track-sequence seq --map map.npz --odometry odo.txt --no-store --out e.txt",
             setup=nonregular("odo.txt", kind), names=["odo.txt"], timeout=30)
    case("non-regular path", "track-sequence DIR is a file", "navbench track-sequence views.npz --map map.npz --no-store", names=["views.npz"])
    case("non-regular path", "import-views DIR is /dev/zero", "navbench import-views /dev/zero --out v2.npz", names=["/dev/zero"])
    case("non-regular path", "import-views --out in missing folder", "navbench import-views seq --out nodir/sub/v.npz", expect="either", allow_new=("nodir",))
    case("non-regular path", "import-views --out /dev/full", "navbench import-views seq --out /dev/full.npz", names=["/dev/full"])
    case("non-regular path", "track-sequence --out is a dir", "navbench track-sequence seq --map map.npz --no-store --out seq", names=["seq"])
    case("non-regular path", "track-sequence --out /dev/full", "navbench track-sequence seq --map map.npz --no-store --out /dev/full", names=["/dev/full"])
    case("non-regular path", "export-views into non-empty dir", "navbench export-views views.npz seq", names=["seq"])
    case("non-regular path", "render-sequence into non-empty dir", "navbench render-sequence house-1 seq --frames 3", names=["seq"])
    case("non-regular path", "render-sequence OUT is a file", "navbench render-sequence house-1 views.npz --frames 3", names=["views.npz"])
    case("non-regular path", "export-trajectories DIR is file", "navbench export-trajectories views.npz", names=["views.npz"])
    case("non-regular path", "export-trajectories DIR non-empty", "navbench export-trajectories seq", names=["seq"])
    case("non-regular path", "report --out is a file", "navbench report --out views.npz", names=["views.npz"])
    case("non-regular path", "report --out is /dev/null", "navbench report --out /dev/null", names=["/dev/null"])
    case("non-regular path", "report --out inside levels", "navbench report --out levels", names=["levels"])
    case("non-regular path", "report --levels is a file", "navbench report --levels views.npz --out rep2", names=["views.npz"], allow_new=("rep2",))
    case("non-regular path", "show-level --out is dir", "navbench show-level house-1 --out seq", names=["seq"])
    case("non-regular path", "show-level --out /dev/full", "navbench show-level house-1 --out /dev/full", names=["/dev/full"])
    case("non-regular path", "make-level from-houseexpo fifo", "navbench make-level hx --from-houseexpo he.json",
         setup=nonregular("he.json", "fifo"), names=["he.json"], timeout=30)
    case("non-regular path", "make-level from-houseexpo dir", "navbench make-level hx --from-houseexpo he.json",
         setup=nonregular("he.json", "dir"), names=["he.json"], timeout=30)
    for n, t in [("malformed", "{"), ("deep", DEEP_JSON), ("empty obj", "{}"),
                 ("30000 verts", json.dumps({"id": "x", "verts": [[float(i % 97), float(i // 97)] for i in range(30000)], "bbox": {"min": [0, 0], "max": [300, 300]}})),
                 ("NaN verts", '{"id":"x","verts":[[NaN,0],[1,0],[1,1]],"bbox":{"min":[0,0],"max":[1,1]}}')]:
        case("level-json", f"houseexpo {n}", "navbench make-level hx --from-houseexpo he.json --seed 1",
             setup=wfile("he.json", t), names=["he.json"], timeout=60, allow_new=("levels/hx.json",))

    # ---------------------------------------------------------------- absurd numbers, CLI
    absurd = [
        "make-level lv --seed 1 --size 1e9", "make-level lv --seed 1 --size nan", "make-level lv --seed 1 --size inf",
        "make-level lv --seed 1 --size -5", "make-level lv --seed 1 --size 0", "make-level lv --seed 1 --size 0.01",
        "make-level lv --seed 1 --rooms 1000000", "make-level lv --seed 1 --rooms -3", "make-level lv --seed 1 --rooms 0",
        "make-level lv --seed 1 --obstacles 100000000", "make-level lv --seed 1 --obstacles -1",
        "make-level lv --seed -1", "make-level lv --seed 99999999999999999999999",
        "make-level lv --changed-from house-1 --changes -2 --seed 1", "make-level lv --changed-from house-1 --changes 100000000 --seed 1",
        "make-level lv --kind maze --seed 1 --size 1e-3",
        "collect-views house-1 --count 9223372036854775807", "collect-views house-1 --count 0", "collect-views house-1 --seed -1 --count 5",
        "sample-tasks house-1 --count 9223372036854775807 --out t2", "sample-tasks house-1 --count 0 --out t2",
        "level-difficulty house-1 --count 0", "level-difficulty house-1 --count 99999999999999999999",
        f"run-navigation house-1 --chunk 0 {TINY}", f"run-navigation house-1 --chunk 9223372036854775807 {TINY} --estimators dynamics",
        f"run-navigation house-1 --tasks 0 {TINY}", f"run-navigation house-1 --seeds 0 {TINY}", f"run-navigation house-1 --workers -1 {TINY}",
        f"run-navigation house-1 --workers 100000 {TINY}",
        "track-eval house-1 --map map.npz --kidnap-every 0 --trajectories 1 --steps 3 --no-store",
        "track-eval house-1 --map map.npz --kidnap-every -1 --trajectories 1 --steps 3 --no-store",
        "track-eval house-1 --map map.npz --kidnap-every 1 --trajectories 1 --steps 2 --estimators no-map --no-store",
        "track-eval house-1 --map map.npz --kidnap-every 9223372036854775807 --trajectories 1 --steps 2 --estimators no-map --no-store",
        "track-eval house-1 --map map.npz --steps 0 --no-store", "track-eval house-1 --map map.npz --seed -1 --steps 2 --trajectories 1 --no-store",
        "localize-eval house-1 --map map.npz --queries 0 --no-store", "localize-eval house-1 --map map.npz --seed -1 --queries 2 --no-store",
        "score --boot 0", "score --boot 1000000000", "score --seed -1", "compare --seed -1 --pair no-map:ours",
        "compare --boot 0", "report --trajectories -1 --out rep2", "report --boot 0 --out rep2",
        "export-trajectories ex --dt nan", "export-trajectories ex --dt inf", "export-trajectories ex --dt -0.1",
        "export-trajectories ex --dt 0", "export-trajectories ex --dt 1e308",
        "render-sequence house-1 s2 --frames 1", "render-sequence house-1 s2 --frames -4", "render-sequence house-1 s2 --frames 3 --seed -1",
        "show-level house-1 --dpi 0 --out o.png", "show-level house-1 --dpi 100000 --out o.png",
        "fit-map house-1 --steps 0", "fit-map house-1 --heldout-every 1 --views views.npz --steps 2",
        "fit-map --views views.npz --steps 2 --heldout-every 100000",
        "cache gc --keep-newest -1", "bench --repeats 0 --no-store", "bench --e2e-tasks -1 --no-store",
    ]
    for c in absurd:
        exp = "either" if c.startswith(("score --seed", "compare --seed", "export-trajectories ex --dt 1e308")) else "error"
        case("absurd numbers", c[:70], f"navbench {c}", expect=exp,
             allow_new=("lv", "levels/lv.json", "t2", "rep2", "ex", "s2", "o.png", "results/levels"), timeout=90)

    # ---------------------------------------------------------------- environment garbage
    envs = [
        ("NUMBA_NUM_THREADS=0", {"NUMBA_NUM_THREADS": "0"}), ("NUMBA_NUM_THREADS=abc", {"NUMBA_NUM_THREADS": "abc"}),
        ("NUMBA_NUM_THREADS=-1", {"NUMBA_NUM_THREADS": "-1"}), ("NUMBA_NUM_THREADS=99999", {"NUMBA_NUM_THREADS": "99999"}),
        ("NUMBA_NUM_THREADS=''", {"NUMBA_NUM_THREADS": ""}), ("OMP_NUM_THREADS=abc", {"OMP_NUM_THREADS": "abc"}),
        ("OMP_NUM_THREADS=0", {"OMP_NUM_THREADS": "0"}), ("OMP_NUM_THREADS=1e9", {"OMP_NUM_THREADS": "1000000000"}),
        ("MKL_NUM_THREADS=x", {"MKL_NUM_THREADS": "x"}), ("MPLBACKEND=nope", {"MPLBACKEND": "nope"}),
        ("MPLBACKEND=TkAgg", {"MPLBACKEND": "TkAgg"}), ("MPLBACKEND=''", {"MPLBACKEND": ""}),
        ("NAVBENCH_CACHE=/dev/null", {"NAVBENCH_CACHE": "/dev/null"}), ("NAVBENCH_CACHE=file", {"NAVBENCH_CACHE": "views.npz"}),
        ("NAVBENCH_CACHE=/proc/x", {"NAVBENCH_CACHE": "/proc/probe2/x"}), ("NAVBENCH_CACHE=''", {"NAVBENCH_CACHE": ""}),
        ("NAVBENCH_CACHE=levels (not a cache)", {"NAVBENCH_CACHE": "levels"}),
        ("NAVBENCH_DB=garbage", {"NAVBENCH_DB": "garbage://x"}), ("NAVBENCH_DB=sqlite nonexistent dir", {"NAVBENCH_DB": "sqlite:////nonexistent/dir/x.db"}),
        ("NAVBENCH_DB=postgres unreachable", {"NAVBENCH_DB": "postgresql://u:p@127.0.0.1:1/db"}),
        ("NAVBENCH_DB=sqlite on dir", {"NAVBENCH_DB": "sqlite:///levels"}), ("NAVBENCH_DB=plain path", {"NAVBENCH_DB": "my.db"}),
        ("NUMBA_CACHE_DIR=/proc/x", {"NUMBA_CACHE_DIR": "/proc/probe2/x"}), ("NUMBA_CACHE_DIR=file", {"NUMBA_CACHE_DIR": "SENTINEL-root.txt"}),
        ("PYTHONIOENCODING=ascii", {"PYTHONIOENCODING": "ascii"}), ("LANG=C LC_ALL=C", {"LANG": "C", "LC_ALL": "C"}),
        ("TMPDIR=/nonexistent", {"TMPDIR": "/nonexistent/probe2"}), ("HOME unset", {"HOME": None}),
        ("HOME=/nonexistent", {"HOME": "/nonexistent/probe2"}), ("COLUMNS=0", {"COLUMNS": "0"}), ("COLUMNS=-5", {"COLUMNS": "-5"}),
        ("TERM=dumb NO_COLOR", {"TERM": "dumb", "NO_COLOR": "1"}),
    ]
    for n, e in envs:
        exp = "either"
        case("environment", f"{n} :: all", TINY_ALL, env=e, expect=exp, timeout=150,
             allow_new=("my.db", "results"))
        case("environment", f"{n} :: score", "navbench score --boot 50", env=e, expect=exp, timeout=60, allow_new=("my.db",))
    # filesystem environment
    fsenv = [
        ("results/cache is a file", chain(shell_setup("rm -rf results/cache"), wfile("results/cache", "i am a file"))),
        ("results is a file", chain(shell_setup("mv results results.bak"), wfile("results", "file"))),
        ("results/navbench.db is a dir", chain(shell_setup("rm results/navbench.db"), nonregular("results/navbench.db", "dir"))),
        ("results/navbench.db garbage", wfile("results/navbench.db", BINARY)),
        ("results/navbench.db empty", wfile("results/navbench.db", b"")),
        ("results/navbench.db truncated", shell_setup("head -c 9000 results/navbench.db > x && mv x results/navbench.db")),
        ("results/navbench.db fifo", chain(shell_setup("rm results/navbench.db"), nonregular("results/navbench.db", "fifo"))),
        ("results/navbench.db -> /dev/zero", chain(shell_setup("rm results/navbench.db"), nonregular("results/navbench.db", "devzero"))),
        ("results/report is a file", chain(shell_setup("rm -rf results/report"), wfile("results/report", "file"))),
        ("results/cache/refs is a file", chain(shell_setup("rm -rf results/cache/refs"), wfile("results/cache/refs", "x"))),
        ("results/cache/fit-map is a file", chain(shell_setup("rm -rf results/cache/fit-map"), wfile("results/cache/fit-map", "x"))),
        ("results/cache/.holds is a file", chain(shell_setup("rm -rf results/cache/.holds"), wfile("results/cache/.holds", "x"))),
        ("cache symlink loop", chain(shell_setup("rm -rf results/cache"), nonregular("results/cache", "loop"))),
        ("cache -> /dev/null", chain(shell_setup("rm -rf results/cache"), nonregular("results/cache", "devzero"))),
        ("levels is a file", chain(shell_setup("rm -rf levels"), wfile("levels", "x"))),
        ("cwd read-only (chattr not available; chmod 555 is ignored by root)", shell_setup("chmod -R a-w results")),
    ]
    for n, setup in fsenv:
        for c in [TINY_ALL, "navbench score --boot 50", "navbench cache ls"]:
            case("environment", f"{n} :: {c.split()[1]}", c, setup=setup, expect="error" if "garbage" in n or "dir" in n or "fifo" in n or "zero" in n else "either",
                 timeout=150, allow_new=("results",))

    # ---------------------------------------------------------------- cache corruption then rerun
    def art(stage, fname=None):
        return f"$(ls -d results/cache/{stage}/*/ | head -1){fname or ''}"
    corrupt = [
        ("fit-map map.npz truncated", f"f={art('fit-map','map.npz')}; head -c 1000 $f > x; cat x > $f"),
        ("fit-map map.npz garbled", f"f={art('fit-map','map.npz')}; printf 'XXXX' | dd of=$f bs=1 seek=5000 conv=notrunc 2>/dev/null"),
        ("fit-map map.npz deleted", f"rm {art('fit-map','map.npz')}"),
        ("fit-map manifest truncated", f"f={art('fit-map','manifest.json')}; head -c 50 $f > x; cat x > $f"),
        ("fit-map manifest deep", f"f={art('fit-map','manifest.json')}; python3 -c \"print('['*5000+']'*5000)\" > $f"),
        ("fit-map manifest binary", f"f={art('fit-map','manifest.json')}; head -c 3000 /dev/urandom > $f"),
        ("fit-map manifest removed", f"rm {art('fit-map','manifest.json')}"),
        ("fit-map manifest wrong sha", f"f={art('fit-map','manifest.json')}; sed -i 's/\"sha256\": \"4/\"sha256\": \"5/' $f"),
        ("fit-map manifest size huge", f"f={art('fit-map','manifest.json')}; sed -i 's/\"size\": [0-9]*/\"size\": 99999999999999999999/' $f"),
        ("fit-map manifest is dir", f"f={art('fit-map','manifest.json')}; rm $f; mkdir $f"),
        ("fit-map manifest is fifo", f"f={art('fit-map','manifest.json')}; rm $f; mkfifo $f"),
        ("fit-map map.npz -> /dev/zero", f"f={art('fit-map','map.npz')}; rm $f; ln -s /dev/zero $f"),
        ("fit-map artifact is file", f"d={art('fit-map')}; rm -rf $d; echo x > ${{d%/}}"),
        ("fit-map artifact symlink loop", f"d={art('fit-map')}; d=${{d%/}}; rm -rf $d; ln -s $d $d"),
        ("collect-views depth_valid truncated", f"for d in results/cache/collect-views/*/views; do f=$(ls $d/*.np* | head -1); head -c 500 $f > x; cat x > $f; done"),
        ("collect-views views.json deep", "for d in results/cache/collect-views/*/views; do python3 -c \"print('['*5000+']'*5000)\" > $d/views.json; done"),
        ("collect-views views.json NaN count", "for d in results/cache/collect-views/*/views; do sed -i 's/\"count\": [0-9]*/\"count\": NaN/' $d/views.json; done"),
        ("episode npz truncated", "for f in results/cache/episode/*/episode.npz; do head -c 100 $f > x; cat x > $f; done"),
        ("episode manifests removed", "rm -f results/cache/episode/*/manifest.json"),
        ("sample-tasks artifact garbled", f"for f in {art('sample-tasks')}*; do [ -f $f ] && printf '{{' > $f; done"),
        ("refs garbage", "printf 'garbage' > results/cache/refs/all-quick.json"),
        ("refs deep", "python3 -c \"print('['*5000+']'*5000)\" > results/cache/refs/all-quick.json"),
        ("refs dangling link", "rm results/cache/refs/all-quick.json; ln -s /nonexistent results/cache/refs/all-quick.json"),
        ("marker garbage", "head -c 500 /dev/urandom > results/cache/.navbench-cache"),
        ("marker removed", "rm results/cache/.navbench-cache"),
        ("marker is dir", "rm results/cache/.navbench-cache; mkdir results/cache/.navbench-cache"),
        ("holds garbage", "mkdir -p results/cache/.holds; head -c 500 /dev/urandom > results/cache/.holds/1-x.hold; printf '99999999 x\\nfit-map/abc\\n' > results/cache/.holds/99999999-y.hold"),
        ("holds claims pid 1 holds everything", "mkdir -p results/cache/.holds; (echo '1 token host'; for d in results/cache/*/*/; do s=$(basename $(dirname $d)); k=$(basename $d); echo $s/$k; done) > results/cache/.holds/1-a.hold"),
        ("stale tmp folder", "mkdir -p results/cache/fit-map/.tmp-abc-999999-xyz; echo x > results/cache/fit-map/.tmp-abc-999999-xyz/f"),
        ("unknown stage folder", "mkdir -p results/cache/frobnicate/abc; echo mine > results/cache/frobnicate/abc/SENT.txt"),
        ("db row with NaN planted", "sqlite3 results/navbench.db \"update episodes set spl_term=1e999 where id=1\""),
        ("db runs table dropped", "sqlite3 results/navbench.db 'drop table runs'"),
        ("db episodes table dropped", "sqlite3 results/navbench.db 'drop table episodes'"),
        ("db meta version 999", "sqlite3 results/navbench.db \"update navbench_meta set value='999'\""),
        ("db run stuck running with dead pid", "sqlite3 results/navbench.db \"update runs set status='running', pid=999999, finished=NULL\""),
    ]
    for n, script in corrupt:
        cmds = [TINY_ALL, "navbench cache ls"] + (["navbench score --boot 50", "navbench report --out rep2 --boot 50"] if n.startswith(("db ", "refs", "marker")) else [])
        for c in cmds:
            case("cache corruption", f"{n} :: {' '.join(c.split()[1:2])}", c, setup=shell_setup(script), expect="either",
                 timeout=180, allow_remove=("results/cache/",), allow_new=("results/cache/", "rep2", "results/report"),
                 check=check_rerun if c == TINY_ALL else None)

    # ---------------------------------------------------------------- cache gc with wrong roots
    gc_roots = [
        ("--root results", "results"), ("--root .", "."), ("--root ..", ".."), ("--root levels", "levels"),
        ("--root seq", "seq"), ("--root results/report", "results/report"), ("--root results/cache/fit-map", "results/cache/fit-map"),
        ("--root results/cache/fit-map/KEY", "$(ls -d results/cache/fit-map/*/ | grep -v my-notes | head -1)"),
        ("--root home-like", "fakehome"), ("--root outside", "outside"), ("--root missing", "nope/cache"),
        ("--root file", "views.npz"), ("--root /dev/null", "/dev/null"), ("--root fifo", "fifo"), ("--root loop", "loop"),
        ("--root empty dir", "emptydir"), ("--root ''", "''"), ("--root results/cache/", "results/cache/"),
        ("--root symlink to cache", "cachelink"), ("--root results/cache/refs", "results/cache/refs"),
        ("--root forged marker dir", "forged"), ("--root forged layout", "forged2"), ("--root copied cache", "copied"),
    ]

    def gc_setup(d: Path):
        subprocess.run("""
        mkdir -p fakehome/.config fakehome/projects/a/b emptydir; echo keep > fakehome/.bashrc; echo keep > fakehome/projects/a/b/x
        mkfifo fifo; ln -s loop loop2; ln -s loop2 loop; ln -s results/cache cachelink
        mkdir -p forged/fit-map/k1 forged/refs; echo '{"x":1}' > forged/.navbench-cache; echo keep > forged/fit-map/k1/file
        mkdir -p forged2/fit-map/0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef forged2/refs
        echo keep > forged2/fit-map/0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef/notes.txt
        cp -a results/cache copied; echo keep > copied/fit-map/my-notes/extra.txt
        mkdir -p results/cache/fit-map/userdir/inner; echo keep > results/cache/fit-map/userdir/inner/SENT.txt
        echo keep > results/cache/fit-map/loose-SENT.txt
        ln -s ../../../outside/keep results/cache/fit-map/linkout
        mkdir -p results/cache/episode/.bad-fake; echo keep > results/cache/episode/.bad-fake/SENT.txt
        ln -s ../../../outside/keep results/cache/episode/.tmp-linked-1-x
        d=$(ls -d results/cache/fit-map/*/ | grep -v -e my-notes -e userdir | head -1); echo keep > ${d}USER-SENT.txt
        """, shell=True, cwd=d, check=True)

    gc_sentinels = ["fakehome/.bashrc", "fakehome/projects/a/b/x", "forged/fit-map/k1/file",
                    "forged2/fit-map/0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef/notes.txt",
                    "copied/fit-map/my-notes/extra.txt", "results/cache/fit-map/userdir/inner/SENT.txt",
                    "results/cache/fit-map/loose-SENT.txt", "outside/keep/SENTINEL-outside.txt",
                    "results/navbench.db", "results/report/index.html", "levels/house-1.json", "seq/rgb.txt", "views.npz",
                    "map.npz"]

    def gc_check(extra_keep=()):
        def chk(d, res):
            issues = []
            for s in gc_sentinels + list(extra_keep):
                if not (d / s).exists():
                    issues.append(("DATA-LOSS", f"gc removed {s}"))
            return issues
        return chk

    for n, root in gc_roots:
        for flags in ["--keep-newest 0", "--keep-newest 0 --dry-run", ""]:
            exp = "either" if root in ("results/cache/", "cachelink", "copied", "emptydir", "nope/cache", "''", "forged", "forged2") else "error"
            case("cache gc roots", f"gc {n} {flags}", f"navbench cache gc --root {root} {flags}", setup=gc_setup,
                 expect=exp, check=gc_check(), allow_remove=("results/cache/", "copied/", "emptydir"),
                 allow_new=("nope", "emptydir", "results/cache"), timeout=60)
    case("cache gc roots", "gc NAVBENCH_CACHE=results", "navbench cache gc --keep-newest 0", env={"NAVBENCH_CACHE": "results"},
         setup=gc_setup, check=gc_check(), timeout=60)
    case("cache gc roots", "gc NAVBENCH_CACHE=.", "navbench cache gc --keep-newest 0", env={"NAVBENCH_CACHE": "."},
         setup=gc_setup, check=gc_check(), timeout=60)
    case("cache gc roots", "gc default root with user files inside", "navbench cache gc --keep-newest 0", setup=gc_setup,
         expect="ok", check=gc_check(["results/cache/fit-map/my-notes/SENTINEL.txt"]), allow_remove=("results/cache/",), timeout=60)
    case("cache gc roots", "gc dry-run == real", "navbench cache gc --keep-newest 0 --dry-run > dry.txt && navbench cache gc --keep-newest 0 > real.txt; cat dry.txt real.txt",
         setup=gc_setup, expect="ok", check=check_dry_equals_real, allow_remove=("results/cache/",), allow_new=("dry.txt", "real.txt"), timeout=60)

    # ---------------------------------------------------------------- interruption
    rnd = random.Random(34)
    kill_cfgs = [
        ("all", f"navbench all --profile quick --set tasks.count=3 --set views.count=60 --set views.eval_count=10 --set fit.steps=20 --set navigation.episode.max_steps=40 --workers 2", 9),
        ("all-refit", f"navbench all --profile quick --set tasks.count=2 --set views.count=60 --set views.eval_count=10 --set fit.steps=60 --set fit.seed=7 --set navigation.episode.max_steps=30 --workers 2", 6),
        ("all-1worker", f"navbench all --profile quick --set tasks.count=3 --set views.count=60 --set views.eval_count=10 --set fit.steps=20 --set navigation.episode.max_steps=40 --workers 1", 9),
    ]
    sigs = [("SIGINT", signal.SIGINT), ("SIGTERM", signal.SIGTERM), ("SIGKILL", signal.SIGKILL)]
    for i in range(15):
        cname, cmd, n_expected = kill_cfgs[i % 3]
        sname, sig = sigs[(i // 3) % 3]
        delay = round(rnd.uniform(1.5, 22.0), 1)
        case("interruption", f"{sname} {cname} at {delay}s", cmd, expect="ok", runner=make_kill_runner(sig, delay, n_expected, group=(i % 2 == 0)),
             timeout=240, allow_remove=("results/cache/",), allow_new=("results",))
    for sname, sig in sigs:
        for delay in (2.0, 6.0):
            case("interruption", f"{sname} standalone fit-map at {delay}s",
                 "navbench fit-map house-1 --set views.count=60 --set views.eval_count=10 --set fit.steps=150 --set fit.seed=3",
                 expect="ok", runner=make_kill_runner(sig, delay, None), timeout=240, allow_remove=("results/cache/",), allow_new=("results",))
            case("interruption", f"{sname} report at {delay / 4}s", "navbench report --out rep3 --boot 200",
                 expect="ok", runner=make_kill_runner(sig, delay / 4, None), timeout=120, allow_new=("rep3", "results"))
            case("interruption", f"{sname} import-views --store at {delay / 8}s", "navbench import-views seq12 --store",
                 expect="ok", runner=make_kill_runner(sig, delay / 8, None), timeout=120, allow_new=("results",))

    # ---------------------------------------------------------------- concurrent pairs
    pairs = [
        ("two import-views same --out", "navbench import-views seq --out same.npz", "navbench import-views seq12 --out same.npz", check_one_writer_or_refused("same.npz")),
        ("two import-views same --out dir", "navbench import-views seq --out samedir", "navbench import-views seq12 --out samedir", check_one_writer_or_refused("samedir")),
        ("two sample-tasks same out", "navbench sample-tasks house-1 --count 2 --out tt", "navbench sample-tasks house-1 --count 2 --out tt", check_pair_either),
        ("two make-level same name", "navbench make-level lvx --seed 1", "navbench make-level lvx --seed 2", check_one_writer_or_refused("levels/lvx.json")),
        ("two render-sequence same OUT", "navbench render-sequence house-1 rs --frames 4", "navbench render-sequence house-1 rs --frames 5 --seed 3", check_one_writer_or_refused("rs")),
        ("two export-views same DIR", "navbench export-views views.npz exv", "navbench export-views views.npz exv", check_one_writer_or_refused("exv")),
        ("two report same --out", "navbench report --out repc --boot 100", "navbench report --out repc --boot 100", check_pair_either),
        ("two track-sequence same --out", "navbench track-sequence seq --map map.npz --no-store --out same.txt", "navbench track-sequence seq --map map.npz --no-store --out same.txt --seed 5", check_pair_either),
        ("two all same db+cache", TINY_ALL.replace("tasks.count=2", "tasks.count=3"), TINY_ALL.replace("tasks.count=2", "tasks.count=3"), check_counts(9)),
        ("all + all different tasks", TINY_ALL.replace("tasks.count=2", "tasks.count=3"), TINY_ALL.replace("--workers 1", "--workers 1 --set tasks.seed=5"), None),
        ("all + gc keep-newest 0", TINY_ALL.replace("tasks.count=2", "tasks.count=3"), "sleep 4; navbench cache gc --keep-newest 0", check_counts(9)),
        ("all + gc keep-newest 0 early", TINY_ALL.replace("fit.steps=20", "fit.steps=60"), "sleep 1.5; navbench cache gc --keep-newest 0", None),
        ("run-navigation x2 same cell", f"navbench run-navigation house-1 {TINY} --set tasks.count=3", f"navbench run-navigation house-1 {TINY} --set tasks.count=3", check_counts(9)),
        ("all + score", TINY_ALL.replace("tasks.count=2", "tasks.count=3"), "sleep 3; navbench score --boot 50", check_counts(9)),
        ("all + report", TINY_ALL.replace("tasks.count=2", "tasks.count=3"), "sleep 3; navbench report --boot 50", check_counts(9)),
        ("import-views --store x2", "navbench import-views seq12 --store", "navbench import-views seq12 --store", None),
        ("fit-map x2 same key", "navbench fit-map house-1 --set views.count=60 --set views.eval_count=10 --set fit.steps=30 --set fit.seed=9",
         "navbench fit-map house-1 --set views.count=60 --set views.eval_count=10 --set fit.steps=30 --set fit.seed=9", None),
        ("gc x2", "navbench cache gc --keep-newest 0", "navbench cache gc --keep-newest 0", None),
        ("track-sequence x2 same db row", "navbench track-sequence seq --map map.npz --out a.txt", "navbench track-sequence seq --map map.npz --out b.txt", None),
        ("show-level x2 same --out", "navbench show-level house-1 --out lvl.png", "navbench show-level house-2 --out lvl.png", check_pair_either),
    ]
    for n, a, b, chk in pairs:
        case("concurrent pairs", n, f"{a} ||| {b}", expect="ok", runner=pair_runner, check=chk, timeout=300,
             allow_remove=("results/cache/", "results/report/"), allow_new=("same.npz", "samedir", "tt", "levels/lvx.json", "rs", "exv", "repc", "same.txt", "results", "a.txt", "b.txt", "lvl.png", "results/cache/"))
    plugin_cases()
    db_url_cases()


def plugin_cases():
    """Hostile plugins: a dist-info folder with entry points on PYTHONPATH (plug/)."""
    def plug(ep_group, ep_line, module_src=None, modname="probeplug"):
        def f(d: Path):
            p = d / "plug"
            di = p / "probeplug-0.1.dist-info"
            di.mkdir(parents=True, exist_ok=True)
            (di / "METADATA").write_text("Metadata-Version: 2.1\nName: probeplug\nVersion: 0.1\n")
            (di / "entry_points.txt").write_text(f"[{ep_group}]\n{ep_line}\n")
            if module_src is not None:
                (p / f"{modname}.py").write_text(module_src)
        return f
    env = {"PYTHONPATH": f"{WT}:plug"}
    good_head = "from navbench_example_src import *\n"
    est_nan = (
        "import numpy as np\n"
        "class NanEst:\n"
        "    name='nanest'; uses_frames=False; uses_map=False; options=None\n"
        "    def __init__(self, vmap=None, intrinsics=None, camera_height=0.5, renderer=None, seed=0, **o):\n"
        "        self.pose=None; self.last_timing={}\n"
        "    def reset(self, pose0, frame0):\n"
        "        self.pose=np.asarray(pose0,float).copy()\n"
        "    def update(self, control, frame, true_pose=None):\n"
        "        self.last_timing={'render':0.0,'estimate':0.0}\n"
        "        return np.array([np.nan, np.nan, np.nan])\n")
    est_raise = est_nan.replace("return np.array([np.nan, np.nan, np.nan])", "raise RuntimeError('plugin bug')")
    est_wrongshape = est_nan.replace("return np.array([np.nan, np.nan, np.nan])", "return np.zeros(7)")
    est_inf = est_nan.replace("np.nan, np.nan, np.nan", "np.inf, 1.0, 0.0")
    rn = f"navbench run-navigation house-1 {TINY}"
    te = "navbench track-eval house-1 --map map.npz --trajectories 1 --steps 5 --no-store"
    cases_ = [
        ("entry point to missing module", "navbench.estimators", "bad = nonexistent_mod_xyz:X", None, f"{rn} --estimators bad", "error"),
        ("module raises at import", "navbench.estimators", "bad = probeplug:X", "raise RuntimeError('boom at import')\n", f"{rn} --estimators bad", "error"),
        ("module SyntaxError", "navbench.estimators", "bad = probeplug:X", "def (:\n", f"{rn} --estimators bad", "error"),
        ("attr missing", "navbench.estimators", "bad = probeplug:Nope", "X = 1\n", f"{rn} --estimators bad", "error"),
        ("object is an int", "navbench.estimators", "bad = probeplug:X", "X = 1\n", f"{rn} --estimators bad", "error"),
        ("malformed value", "navbench.estimators", "bad = a:b:c", None, f"{rn} --estimators bad", "error"),
        ("shadows builtin ours", "navbench.estimators", "ours = probeplug:X", "X = 1\n", f"{rn} --estimators ours,dynamics", "either"),
        ("broken unused plugin, all", "navbench.estimators", "bad = probeplug:X", "raise RuntimeError('boom')\n", TINY_ALL, "either"),
        ("broken unused plugin, score", "navbench.estimators", "bad = probeplug:X", "raise RuntimeError('boom')\n", "navbench score --boot 50", "either"),
        ("module sys.exit(0) at import", "navbench.estimators", "bad = probeplug:X", "import sys; sys.exit(0)\n", f"{rn} --estimators bad", "error"),
        ("module os._exit at import", "navbench.estimators", "bad = probeplug:X", "import os; os._exit(0)\n", f"{rn} --estimators bad", "error"),
        ("estimator returns NaN poses", "navbench.estimators", "nanest = probeplug:NanEst", est_nan, f"{rn} --estimators nanest", "either"),
        ("estimator returns inf poses", "navbench.estimators", "nanest = probeplug:NanEst", est_inf, f"{rn} --estimators nanest", "either"),
        ("estimator raises in update", "navbench.estimators", "nanest = probeplug:NanEst", est_raise, f"{rn} --estimators nanest", "error"),
        ("estimator wrong shape", "navbench.estimators", "nanest = probeplug:NanEst", est_wrongshape, f"{rn} --estimators nanest", "error"),
        ("track-eval NaN estimator", "navbench.estimators", "nanest = probeplug:NanEst", est_nan, f"{te} --estimators nanest", "either"),
        ("track-eval raising estimator", "navbench.estimators", "nanest = probeplug:NanEst", est_raise, f"{te} --estimators nanest", "error"),
        ("track-sequence NaN estimator", "navbench.estimators", "nanest = probeplug:NanEst", est_nan, "navbench track-sequence seq --estimator nanest --out e.txt", "either"),
        ("world model plugin raises", "navbench.world_models", "frob = probeplug:X", "raise RuntimeError('boom')\n", "navbench track-sequence seq --map bad.npz --no-store --out e.txt", "error"),
        ("world model plugin is int", "navbench.world_models", "frob = probeplug:X", "X = 3\n", "navbench track-sequence seq --map bad.npz --no-store --out e.txt", "error"),
        ("estimator plugin name with spaces", "navbench.estimators", "bad name = probeplug:X", "X = 1\n", f"{rn} --estimators dynamics", "either"),
        ("estimator option of plugin via -o", "navbench.estimators", "nanest = probeplug:NanEst", est_nan, f"{rn} --estimators nanest -o nanest.k=3", "error"),
    ]
    import numpy as np
    def frobmap(d):
        z = dict(np.load(BASE / "map.npz"))
        h = json.loads(str(z["header"])); h["kind"] = "frob"; z["header"] = np.array(json.dumps(h))
        with open(d / "bad.npz", "wb") as fh:
            np.savez(fh, **z)
    for n, g, line, src, cmd, exp in cases_:
        setup = plug(g, line, src)
        if "world model" in n:
            setup = chain(setup, frobmap)
        case("plugin files", n, cmd, setup=setup, env=env, expect=exp, timeout=150,
             names=["plugin", "bad", "nanest", "probeplug", "frob"], allow_new=("results",),
             check=check_no_nonfinite)


def db_url_cases():
    urls = [("binary non-db file", "sqlite:///views.npz", "views.npz"), ("text file", "sqlite:///levels/house-1.json", "levels/house-1.json"),
            ("a directory", "sqlite:///levels", None), ("/dev/zero", "sqlite:////dev/zero", None), ("a fifo", "sqlite:///fifo", None),
            ("missing folder", "sqlite:///nonexistent/x.db", None), ("plain path", "results/navbench.db", None),
            ("postgres refused", "postgresql://u:p@127.0.0.1:1/db", None), ("postgres blackhole", "postgresql://u:p@10.255.255.1:5432/db", None),
            ("in-memory", "sqlite://", None), ("unknown driver", "mysql://u:p@localhost/x", None), ("empty", "''", None),
            ("garbage", "'::::'", None), ("sqlite ro uri", "'sqlite:///file:results/navbench.db?mode=ro&uri=true'", None),
            ("password special", "'postgresql://u:p%40ss:w@127.0.0.1:1/db'", None)]
    cmds = ["navbench score --boot 50 --db {u}", "navbench db info --db {u}", "navbench db runs --db {u}",
            f"navbench run-navigation house-1 {TINY} --estimators dynamics --db {{u}}", "navbench compare --pair no-map:ours --b-db {u}",
            "navbench track-sequence seq --map map.npz --out e.txt --db {u}"]
    def fifo(d):
        os.mkfifo(d / "fifo")
    for n, u, keep in urls:
        for c in cmds:
            cmd = c.format(u=u)
            if "db info" in cmd or "db runs" in cmd:
                cmd = cmd.replace(" --db ", " --db ") if "--db" in "navbench db info --help" else cmd
            exp = "either" if n in ("in-memory", "plain path", "sqlite ro uri") else "error"
            case("db URLs", f"{n} :: {' '.join(c.split()[1:3])}", cmd, setup=fifo, expect=exp, timeout=90,
                 names=["db", "database", "--db", "--b-db", "url"], allow_new=("results/sequences", "e.txt", "results"))


def check_no_nonfinite(d, res):
    issues = []
    p = d / "results/navbench.db"
    if not p.exists():
        return issues
    con = sqlite3.connect(p)
    try:
        for t, cols in [("episodes", ["loc_rmse_m", "rot_rmse_deg", "spl_term", "path_length", "final_dist_m"]),
                        ("tracking", ["loc_rmse_m", "rot_rmse_deg"]), ("sequence_tracking", ["ate_m", "rpe_m"])]:
            for col in cols:
                try:
                    n = con.execute(f"select count(*) from {t} where estimator like 'nanest%' and ({col} is null or {col} > 1e308 or {col} < -1e308)").fetchone()[0]
                except sqlite3.DatabaseError:
                    continue
                if n:
                    issues.append(("INVALID-RESULT", f"{n} rows of {t} with {col} NULL/non-finite from a NaN estimator"))
    finally:
        con.close()
    return issues


def sh_quote(s):
    return "'" + s.replace("'", "'\\''") + "'"


# --------------------------------------------------------------------------- special checks

def check_rerun(d, res):
    """After cache corruption, a rerun that succeeds must store exactly the 6 episodes once."""
    issues = []
    if res["rc"] == 0:
        m = re.search(r"(\d+)/(\d+) stored", res["out"])
        if not m or m.group(1) != m.group(2) or m.group(2) != "6":
            issues.append(("DATA-LOSS", f"rerun stored count line: {m.group(0) if m else 'missing'}"))
    return issues


def check_dry_equals_real(d, res):
    dry = (d / "dry.txt").read_text() if (d / "dry.txt").exists() else ""
    real = (d / "real.txt").read_text() if (d / "real.txt").exists() else ""
    a = sorted(ln.split(" ", 2)[2] for ln in dry.splitlines() if ln.startswith("would remove "))
    b = sorted(ln.split(" ", 1)[1] for ln in real.splitlines() if ln.startswith("removed "))
    if a != b:
        return [("WRONG-MESSAGE", f"dry-run lists {len(a)} paths, real run removed {len(b)}: {sorted(set(a) ^ set(b))[:4]}")]
    return []


def check_counts(n):
    def chk(d, res):
        st = db_state(d / "results/navbench.db") or {}
        con = sqlite3.connect(d / "results/navbench.db")
        try:
            newest = con.execute("select count(*) from episodes where run_id > 1").fetchone()[0]
        except sqlite3.DatabaseError:
            newest = -1
        con.close()
        if newest != n:
            return [("DATA-LOSS", f"expected {n} new episodes after both finished, found {newest} (rc {res['rcs']})")]
        return []
    return chk


def check_pair_either(d, res):
    """Both may succeed (the later write wins) or one may be refused with an error line."""
    if 0 not in res["rcs"]:
        return [("DATA-LOSS", f"neither member succeeded: {res['rcs']}")]
    return []


def check_one_writer_or_refused(rel):
    def chk(d, res):
        rcs = res["rcs"]
        if rcs == [0, 0]:
            return [("DATA-LOSS", f"both writers of {rel} exited 0; the output holds only one of them")]
        if 0 not in rcs:
            return [("DATA-LOSS", f"neither writer of {rel} succeeded: {rcs}")]
        return []
    return chk


def kill_tree_pids(pid):
    out = subprocess.run(["ps", "-e", "-o", "pid=,ppid="], capture_output=True, text=True).stdout
    kids = {}
    for ln in out.splitlines():
        p, pp = map(int, ln.split())
        kids.setdefault(pp, []).append(p)
    res, stack = [], [pid]
    while stack:
        p = stack.pop()
        res.append(p)
        stack.extend(kids.get(p, []))
    return res


def procs_in(d: Path):
    found = []
    for p in Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                if os.readlink(p / "cwd").startswith(str(d)):
                    found.append(int(p.name))
            except OSError:
                pass
    return found


def make_kill_runner(sig, delay, n_expected, group=False):
    def runner(c: Case, d: Path, env):
        t0 = time.time()
        # a shell started in the background (nohup ... &) ignores SIGINT, and a Python started with SIGINT
        # ignored never installs KeyboardInterrupt: restore the default as a terminal's Ctrl-C sees it
        p = subprocess.Popen("exec " + c.cmd, shell=True, cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True, start_new_session=True,
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        time.sleep(delay)
        finished_before = p.poll() is not None
        if not finished_before:
            # the shell exec's navbench; signal the navbench process (or the whole group, as Ctrl-C does)
            if group or sig == signal.SIGINT:
                os.killpg(p.pid, sig)
            else:
                os.kill(p.pid, sig)
        try:
            out1, _ = p.communicate(timeout=c.timeout)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            out1, _ = p.communicate()
            return {"rc": None, "out": out1, "err": "", "timeout": True, "extra": [("HANG", f"did not stop {c.timeout}s after {sig.name}")]}
        rc1 = p.returncode
        time.sleep(1.0)
        extra = []
        orphans = [x for x in procs_in(d)]
        if orphans:
            extra.append(("DATA-LOSS", f"orphan processes after {sig.name}: {orphans}"))
            for x in orphans:
                try:
                    os.kill(x, signal.SIGKILL)
                except OSError:
                    pass
        if not finished_before and sig == signal.SIGINT and rc1 != 130:
            extra.append(("WRONG-EXIT", f"SIGINT exit {rc1}, expected 130"))
        if "Traceback (most recent call last)" in out1 and sig != signal.SIGKILL:
            extra.append(("TRACEBACK", f"traceback after {sig.name}: " + last_lines(out1, 3)))
        leftover_build = list(d.glob("**/.report.*")) + list(d.glob("**/.tmp-*"))
        # rerun
        r2 = subprocess.run(c.cmd, shell=True, cwd=d, env=env, capture_output=True, text=True, timeout=c.timeout)
        out = f"--- first run (signal {sig.name} at {delay}s, finished before: {finished_before}, rc {rc1}):\n{out1}\n--- rerun rc {r2.returncode}:\n{r2.stdout}{r2.stderr}"
        if r2.returncode != 0:
            extra.append(("DATA-LOSS", f"rerun after {sig.name} failed rc {r2.returncode}: {last_lines(r2.stdout + r2.stderr, 2)}"))
        if n_expected is not None and r2.returncode == 0:
            m = re.search(r"(\d+)/(\d+) stored", r2.stdout + r2.stderr)
            if not m or m.group(1) != m.group(2) or int(m.group(2)) != n_expected:
                extra.append(("DATA-LOSS", f"rerun stored-count line {m.group(0) if m else 'missing'} (expected {n_expected}/{n_expected})"))
        st = db_state(d / "results/navbench.db") or {}
        if st.get("running"):
            extra.append(("DATA-LOSS", f"runs stuck running after rerun: {st['running']}"))
        # a dead writer's .tmp-KEY-PID-RAND inside the cache is documented as collected by `cache gc` (checked
        # by hand on case 1081), so only leftovers elsewhere count
        left2 = [str(x.relative_to(d)) for x in list(d.glob("**/.report.*")) + list(d.glob("**/.tmp-*"))
                 if not str(x.relative_to(d)).startswith("results/cache/")]
        if left2:
            extra.append(("DATA-LOSS", f"temporary folders left after rerun: {left2[:3]}"))
        if "Traceback (most recent call last)" in r2.stdout + r2.stderr:
            extra.append(("TRACEBACK", "traceback in rerun: " + last_lines(r2.stdout + r2.stderr, 3)))
        return {"rc": r2.returncode, "out": out, "err": "", "timeout": False, "extra": extra,
                "note": f"first rc {rc1}, leftovers before rerun {len(leftover_build)}"}
    return runner


def pair_runner(c: Case, d: Path, env):
    a, b = c.cmd.split(" ||| ")
    pa = subprocess.Popen(a, shell=True, cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    pb = subprocess.Popen(b, shell=True, cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    outs, rcs, extra = [], [], []
    for p in (pa, pb):
        try:
            o, _ = p.communicate(timeout=c.timeout)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            o, _ = p.communicate()
            extra.append(("HANG", "a member of the pair hung"))
        outs.append(o)
        rcs.append(p.returncode)
    out = f"--- A rc {rcs[0]}: {a}\n{outs[0]}\n--- B rc {rcs[1]}: {b}\n{outs[1]}"
    for o in outs:
        if "Traceback (most recent call last)" in o:
            extra.append(("TRACEBACK", last_lines(o, 3)))
    for rc, o in zip(rcs, outs):
        if rc not in (0, None) and not re.search(r"^(error|Error)", o, re.M):
            extra.append(("WRONG-MESSAGE", f"a pair member failed rc {rc} without an error line: {last_lines(o, 2)}"))
    # for pairs expected to both succeed (same cache/db), a failure is itself a finding
    if any(rc not in (0,) for rc in rcs) and c.check is None:
        extra.append(("DATA-LOSS", f"pair exit codes {rcs}: one of two concurrent commands failed: {last_lines(outs[rcs.index(next(r for r in rcs if r != 0))], 1)}"))
    return {"rc": 0 if not extra else 1, "rcs": rcs, "out": out, "err": "", "timeout": False, "extra": extra}


def last_lines(s, n):
    ls = [ln for ln in s.strip().splitlines() if ln.strip()]
    return " | ".join(ls[-n:])[:400]


# --------------------------------------------------------------------------- running


def run_case(idx: int, c: Case) -> dict:
    d = Path(f"/tmp/probe2-case-{idx:04d}")
    shutil.rmtree(d, ignore_errors=True)
    shutil.copytree(BASE, d, symlinks=True)
    (d / "home").mkdir(exist_ok=True)
    for s in SENTINELS:
        p = d / s
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(f"sentinel {s}\n")
    setup_err = None
    try:
        if c.setup:
            c.setup(d)
    except Exception as exc:  # noqa: BLE001
        setup_err = f"{type(exc).__name__}: {exc}"
    env = base_env(d)
    for k, v in c.env.items():
        if v is None:
            env.pop(k, None)
        else:
            env[k] = v
    pre = snapshot(d)
    db_pre = db_state(d / c.db)
    t0 = time.time()
    if setup_err:
        res = {"rc": None, "out": "", "err": setup_err, "timeout": False, "extra": [], "setup_error": True}
    elif c.runner:
        try:
            res = c.runner(c, d, env)
        except subprocess.TimeoutExpired:
            res = {"rc": None, "out": "", "err": "", "timeout": True, "extra": []}
    else:
        p = subprocess.Popen(c.cmd, shell=True, cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, errors="replace", start_new_session=True)
        try:
            out, err = p.communicate(timeout=c.timeout)
            res = {"rc": p.returncode, "out": out, "err": err, "timeout": False, "extra": []}
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            out, err = p.communicate()
            res = {"rc": None, "out": out, "err": err, "timeout": True, "extra": []}
    wall = time.time() - t0
    # leftover processes of a hang
    for x in procs_in(d):
        try:
            os.kill(x, signal.SIGKILL)
        except OSError:
            pass
    # restore permissions so we can inspect and delete
    subprocess.run(["chmod", "-R", "u+rwX", str(d)], capture_output=True)
    post = snapshot(d)
    db_post = db_state(d / c.db)
    cls, notes = classify(c, d, res, pre, post, db_pre, db_post)
    rec = {"idx": idx, "class": c.cls, "name": c.name, "cmd": c.cmd[:3000], "env": {k: (v if v is None else v[:200]) for k, v in c.env.items()},
           "expect": c.expect, "rc": res.get("rc"), "rcs": res.get("rcs"), "timeout": res.get("timeout"), "wall_s": round(wall, 2),
           "outcome": cls, "notes": notes, "setup_error": res.get("setup_error", False),
           "stderr_tail": last_lines((res.get("err") or "") + "\n" + (res.get("out") or "") if not res.get("err") else res.get("err"), 4)}
    (OUTDIR / f"{idx:04d}.out").write_text(f"# {c.cls} :: {c.name}\n# cmd: {c.cmd[:3000]}\n# env: {c.env}\n# rc {res.get('rc')} timeout {res.get('timeout')} wall {wall:.1f}s\n"
                                           f"# outcome {cls}: {notes}\n--- stdout\n{(res.get('out') or '')[-20000:]}\n--- stderr\n{(res.get('err') or '')[-20000:]}\n")
    if cls == "OK" and not os.environ.get("PROBE_KEEP"):
        shutil.rmtree(d, ignore_errors=True)
    return rec


def classify(c, d, res, pre, post, db_pre, db_post):
    issues = list(res.get("extra", []))
    rc = res.get("rc")
    text = (res.get("out") or "") + "\n" + (res.get("err") or "")
    err = res.get("err") or ""
    if res.get("setup_error"):
        return "SETUP-ERROR", [res.get("err")]
    if res.get("timeout"):
        issues.append(("HANG", f"no exit within {c.timeout}s"))
    elif rc is not None and (rc < 0 or (rc >= 128 and rc != 130)):
        issues.append(("CRASH", f"exit {rc} (signal {(-rc if rc < 0 else rc - 128)})"))
    if "Traceback (most recent call last)" in text and not c.runner:
        issues.append(("TRACEBACK", last_lines(text[text.find("Traceback"):], 2)))
    if re.search(r"^(Fatal Python error|Segmentation fault)", text, re.M):
        issues.append(("CRASH", last_lines(text, 2)))
    # sentinels
    for s in SENTINELS:
        p = d / s
        if not p.exists() or p.read_text() != f"sentinel {s}\n":
            if s.startswith("results/") and ("results is a file" in c.name):
                continue
            issues.append(("DATA-LOSS", f"sentinel {s} lost or changed"))
    # removed / modified pre-existing files
    dbname = str(Path(c.db))
    for path, meta in pre.items():
        if path.startswith(dbname) or path.startswith(("results.bak",)):
            continue
        allowed = any(path.startswith(a) for a in c.allow_remove)
        if path not in post:
            if not allowed and not (c.runner and path.startswith("results/cache/refs")):
                issues.append(("DATA-LOSS", f"removed {path}"))
        elif post[path] != meta and c.expect == "error" and rc not in (0, None):
            if not allowed and not path.startswith(("results/cache/refs",)):
                issues.append(("DATA-LOSS", f"modified {path}"))
    # db
    if db_post and "error" not in db_post:
        if db_post.get("nonfinite") and db_post["nonfinite"] != (db_pre or {}).get("nonfinite"):
            issues.append(("INVALID-RESULT", f"non-finite or empty scores stored: {db_post['nonfinite'][:4]}"))
        if db_post.get("dups"):
            issues.append(("DATA-LOSS", f"{db_post['dups']} duplicate episode rows"))
        if db_post.get("running") and not c.runner:
            issues.append(("DATA-LOSS", f"runs left 'running': {db_post['running']}"))
        if db_pre and "error" not in db_pre:
            for t, n in db_post["counts"].items():
                if n < db_pre["counts"].get(t, 0) and "dropped" not in c.name:
                    issues.append(("DATA-LOSS", f"table {t} lost rows {db_pre['counts'][t]} -> {n}"))
            if rc not in (0, None) and c.expect == "error":
                grown = {t: n - db_pre["counts"].get(t, 0) for t, n in db_post["counts"].items()
                         if n > db_pre["counts"].get(t, 0) and t not in ("navbench_meta",)}
                if grown:
                    issues.append(("INVALID-RESULT", f"refused command stored rows: {grown}"))
            newfail = set(db_post.get("failed", [])) - set(db_pre.get("failed", []))
            if newfail and c.expect == "error":
                issues.append(("INVALID-RESULT", f"refused command left failed run(s) {sorted(newfail)}"))
    # expectations
    if not c.runner and not res.get("timeout") and rc is not None:
        if c.expect == "error" and rc == 0:
            issues.append(("WRONG-EXIT", "bad input accepted with exit 0: " + last_lines(text, 2)))
        if c.expect == "ok" and rc != 0:
            issues.append(("WRONG-EXIT", f"expected success, exit {rc}: " + last_lines(text, 2)))
        if rc not in (0, 130) and rc > 0 and rc < 128:
            lines = [ln for ln in err.strip().splitlines() if ln.strip() and not ln.lower().startswith("warning")]
            has_err = any(re.match(r"^\s*(error|Error)[: ]", ln) or "Error:" in ln for ln in lines)
            if not has_err and "Traceback" not in text:
                issues.append(("WRONG-MESSAGE", "failed without an error line: " + last_lines(text, 2)))
            boxed = sum(1 for ln in lines if not re.match(r"^\s*(Usage:|Try |\+-|[╭╰│]|error|Error)", ln))
            if has_err and boxed > 3 and "Traceback" not in text:
                issues.append(("WRONG-MESSAGE", f"error is {len(lines)} lines: " + last_lines(err, 3)))
            if rc != 2 and c.expect == "error" and "Traceback" not in text:
                issues.append(("WRONG-EXIT", f"user error exit {rc} (not 2)"))
            if c.names and has_err and "Traceback" not in text:
                emsg = "\n".join(lines).lower()
                if not any(nm.lower() in emsg for nm in c.names):
                    issues.append(("WRONG-MESSAGE", f"error names none of {c.names[:3]}: " + last_lines(err, 1)))
        # new files for refused commands
        if rc not in (0, None) and c.expect in ("error", "either"):
            new = [p for p in post if p not in pre and not any(p.startswith(a) for a in c.allow_new)
                   and not p.startswith(("results/cache/.holds",))]
            if new:
                issues.append(("WRITE-OUTSIDE", f"refused command left new files: {new[:4]}"))
    if c.check:
        try:
            issues += c.check(d, res)
        except Exception as exc:  # noqa: BLE001
            issues.append(("WRONG-MESSAGE", f"check failed: {type(exc).__name__}: {exc}"))
    if not issues:
        return "OK", []
    worst = min(issues, key=lambda x: SEVERITY.index(x[0]))[0]
    return worst, [f"{k}: {v}" for k, v in issues]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default=None)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--out", default="results.jsonl")
    ap.add_argument("--skip-done", action="store_true")
    ap.add_argument("--shuffle", type=int, default=None, help="run the selection in a seeded random order")
    args = ap.parse_args()
    build_base()
    gen_cases()
    sel = [(i, c) for i, c in enumerate(CASES) if args.only is None or args.only in f"{c.cls} :: {c.name}"]
    sel = [(i, c) for i, c in sel if i >= args.start]
    if args.skip_done:
        done = set()
        for f in OUTDIR.glob("results*.jsonl"):
            done |= {json.loads(ln)["idx"] for ln in f.read_text().splitlines()}
        sel = [(i, c) for i, c in sel if i not in done and c.cls != "interruption"]
    if args.list:
        for i, c in sel:
            print(i, c.cls, "::", c.name)
        print(len(sel), "cases")
        return
    OUTDIR.mkdir(parents=True, exist_ok=True)
    lock = threading.Lock()
    t0 = time.time()
    resf = OUTDIR / args.out
    # long cases first so they overlap with short ones
    order = ["cache gc roots", "invalid-result", "concurrent pairs", "interruption", "cache corruption"]
    sel.sort(key=lambda ic: (order.index(ic[1].cls) if ic[1].cls in order else len(order), ic[0]))
    if args.shuffle is not None:
        random.Random(args.shuffle).shuffle(sel)

    def go(ic):
        i, c = ic
        try:
            rec = run_case(i, c)
        except Exception as exc:  # noqa: BLE001
            rec = {"idx": i, "class": c.cls, "name": c.name, "cmd": c.cmd[:300], "outcome": "PROBE-ERROR", "notes": [repr(exc)]}
        with lock:
            with open(resf, "a") as fh:
                fh.write(json.dumps(rec) + "\n")
            print(f"[{time.time() - t0:7.1f}s] {i:4d} {rec['outcome']:14s} {c.cls} :: {c.name[:70]}", flush=True)
        return rec
    with ThreadPoolExecutor(args.jobs) as ex:
        recs = list(ex.map(go, sel))
    print(f"done {len(recs)} cases in {time.time() - t0:.0f}s")


if __name__ == "__main__":
    main()
