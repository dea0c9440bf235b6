"""A seeded hostile-input generator (issue 34), written without reading the earlier probes.

Two families of generators, each a function ``(rng, ctx) -> Case`` that prepares one bad input
in a fresh copy of a small project and says how navbench is to be run on it:

- **files**: for every format navbench reads (level JSON, task sets, profiles, cache
  manifests and refs, ``intrinsics.json``, the TUM lists, map and views files, HouseExpo
  documents) and every kind of damage: ``malformed`` (truncated, binary, not UTF-8, empty),
  ``huge`` (long lists and strings, a file past the size limit), ``deep`` (nesting past the
  recursion limit), ``nonfinite`` (NaN, infinities, overflowing and absurd literals, huge
  integers), ``wrongtype`` (booleans, strings, nulls, containers where numbers are), ``missing``
  (a key removed) and ``nonregular`` (a directory, a FIFO, ``/dev/zero``, a dangling link);
- **options**: for every command a table of its options with values that are invalid for sure
  (non-numbers, NaN, infinities, integers past int64, negatives where a count or seed is
  expected, unknown choices, non-regular paths, deep or non-finite ``-o`` values).

:func:`cases` lists ``n`` cases round-robin over every generator (the first ``len(GENERATORS)``
cover each once), each with its own seed, so case ``k`` is the same on every machine.
``tests/bad_input/test_fuzz.py`` runs them and checks the invariant.
"""

from __future__ import annotations

import json
import math
import os
import random
import shutil
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

DEEP_RANGE = (70, 60_000)     # nesting depth of a "deep" value: past MAX_DEPTH up to far past recursion
HUGE_LIST = 200_000           # elements of a "huge" list
HUGE_TEXT = 3_000_000         # characters of a "huge" string


@dataclass
class Case:
    """One generated input: ``argv`` for the CLI or ``call`` for the library, the file or
    option it damages (``names``: what the one-line error must mention), and whether the
    damaged input might still be valid (``may_pass``: a removed optional key, a value that
    happens to be in range), in which case exit 0 is allowed too."""

    label: str
    argv: list[str] | None = None
    call: Callable[[], Any] | None = None
    names: tuple[str, ...] = ()
    may_pass: bool = False
    outputs: tuple[str, ...] = ()   # project-relative paths the command may write
    cache_may_change: bool = False  # a lookup may quarantine a corrupt cache entry (navbench's own)


@dataclass
class Ctx:
    """The copy of the base project a case runs in (the working directory)."""

    root: Path                # tmp root: proj/, outside/
    proj: Path
    info: dict = field(default_factory=dict)  # keys of the base project's artifacts


# ------------------------------------------------------------------------- value damage

_PLACE = "\u2063PLACEHOLDER\u2063"


def _paths(doc: Any, prefix=()) -> list[tuple]:
    """Every path (tuple of keys/indices) to a value in ``doc`` (at most 400, evenly spread)."""
    out = []
    stack = [(doc, prefix)]
    while stack:
        v, p = stack.pop()
        if p:
            out.append(p)
        if isinstance(v, dict):
            stack.extend((x, p + (k,)) for k, x in v.items())
        elif isinstance(v, list):
            idx = range(len(v)) if len(v) <= 8 else (0, 1, len(v) // 2, len(v) - 1)
            stack.extend((v[i], p + (i,)) for i in idx)
    return out[:: max(1, len(out) // 400)]


def _set(doc: Any, path: tuple, value: Any) -> Any:
    if not path:
        return value
    cur = doc
    for k in path[:-1]:
        cur = cur[k]
    cur[path[-1]] = value
    return doc


def _dumps(doc: Any, raw: str | None) -> str:
    """JSON of ``doc`` with the placeholder string replaced by the raw text ``raw``."""
    text = json.dumps(doc, allow_nan=True)
    return text.replace(json.dumps(_PLACE), raw) if raw is not None else text


def _deep_text(rng: random.Random, toml: bool = False) -> str:
    d = rng.randint(*DEEP_RANGE)
    if rng.random() < 0.5 or toml and rng.random() < 0.5:
        return "[" * d + "]" * d
    if toml:
        return "{a = " * min(d, 3000) + "1" + "}" * min(d, 3000)
    return '{"a":' * d + "1" + "}" * d


NONFINITE_JSON = ["NaN", "Infinity", "-Infinity", "1e400", "-1e400", "1e308", "-1e308", "1e-320",
                  "1" + "0" * 5000, "-" + "9" * 4400]
NONFINITE_TOML = ["nan", "inf", "-inf", "+nan", "1e400", "-1e400", "1e308", "1e-320", "1" + "0" * 5000]
WRONG = [True, False, None, "x", "", [], {}, [1, 2, 3], {"a": 1}, -1, 0, 1.5, "1e3", [None]]


def mutate_json(doc: Any, rng: random.Random, kind: str) -> tuple[bytes, bool]:
    """A damaged JSON text of ``doc`` (a deep copy is changed) and whether it may still pass."""
    doc = json.loads(json.dumps(doc))
    paths = _paths(doc)
    path = rng.choice(paths) if paths else ()
    text = json.dumps(doc)
    if kind == "malformed":
        r = rng.randrange(5)
        if r == 0:
            return text[: rng.randrange(max(1, len(text)))].encode(), False
        if r == 1:
            return b"", False
        if r == 2:
            return bytes(rng.randrange(256) for _ in range(rng.randint(1, 2000))), False
        if r == 3:
            b = text.encode()
            i = rng.randrange(len(b))
            return b[:i] + b"\xff\xfe\xc3" + b[i:], False
        i = rng.randrange(len(text))  # inside a string value the text stays valid JSON
        return (text[:i] + rng.choice(["}", "]", ",", ":", "\"", "{{", "\\u12"]) + text[i:]).encode(), True
    if kind == "deep":
        return _dumps(_set(doc, path, _PLACE), _deep_text(rng)).encode(), False
    if kind == "nonfinite":
        lit = rng.choice(NONFINITE_JSON)  # NaN is refused; 1e-320 or 1e308 may fit a field
        return _dumps(_set(doc, path, _PLACE), lit).encode(), True
    if kind == "wrongtype":
        return json.dumps(_set(doc, path, rng.choice(WRONG))).encode(), True
    if kind == "missing":
        dicts = [p for p in [()] + paths if isinstance(_get(doc, p), dict) and _get(doc, p)]
        p = rng.choice(dicts)
        d = _get(doc, p)
        d.pop(rng.choice(list(d)))
        return json.dumps(doc).encode(), True
    if kind == "huge":
        lists = [p for p in paths if isinstance(_get(doc, p), list) and _get(doc, p)]
        if lists and rng.random() < 0.6:
            p = rng.choice(lists)
            lst = _get(doc, p)
            _set(doc, p, [lst[0]] * HUGE_LIST)
        else:
            _set(doc, path, "x" * HUGE_TEXT)
        return json.dumps(doc).encode(), True
    raise ValueError(kind)


def _get(doc, path):
    for k in path:
        doc = doc[k]
    return doc


def to_toml(doc: dict, raw: str | None = None) -> str:
    """A TOML text of a profile-shaped ``doc`` (top-level keys, tables, nested tables inline);
    the placeholder string becomes the raw text ``raw``."""
    def val(v) -> str:
        if v == _PLACE:
            return raw
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, float):
            return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
        if isinstance(v, int):
            return str(v)
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{json.dumps(k)} = {val(x)}" for k, x in v.items()) + "}"
        if v is None:
            return '"null"'  # TOML has no null: a string where a value is expected
        raise TypeError(type(v))

    top = [f"{json.dumps(k)} = {val(v)}" for k, v in doc.items() if not isinstance(v, dict)]
    tables = [f"[{json.dumps(k)}]\n" + "\n".join(f"{json.dumps(a)} = {val(b)}" for a, b in v.items())
              for k, v in doc.items() if isinstance(v, dict)]
    return "\n".join(top) + "\n\n" + "\n\n".join(tables) + "\n"


def mutate_toml(doc: dict, rng: random.Random, kind: str) -> tuple[bytes, bool]:
    doc = json.loads(json.dumps(doc))
    paths = [p for p in _paths(doc) if len(p) >= 1]
    path = rng.choice(paths)
    if kind == "malformed":
        text = to_toml(doc)
        r = rng.randrange(4)
        if r == 0:
            return text[: rng.randrange(len(text))].encode() + b"\n[[[", False
        if r == 1:
            return bytes(rng.randrange(256) for _ in range(rng.randint(1, 2000))), False
        if r == 2:
            return b"\xff\xfe" + text.encode(), False
        return (text + "\n" + rng.choice(["name = 1", "[views]", "x = ", "= 1", "[a.b"]) + "\n").encode(), False
    if kind == "deep":
        return to_toml(_set(doc, path, _PLACE), _deep_text(rng, toml=True)).encode(), False
    if kind == "nonfinite":
        return to_toml(_set(doc, path, _PLACE), rng.choice(NONFINITE_TOML)).encode(), True
    if kind == "wrongtype":
        return to_toml(_set(doc, path, rng.choice([w for w in WRONG if w is not None]))).encode(), True
    if kind == "missing":
        tables = [p for p in [()] + paths if isinstance(_get(doc, p), dict) and _get(doc, p)]
        p = rng.choice(tables)
        d = _get(doc, p)
        d.pop(rng.choice(list(d)))
        return to_toml(doc).encode(), True
    if kind == "huge":
        if rng.random() < 0.5:
            return to_toml(_set(doc, path, list(range(HUGE_LIST)))).encode(), True
        return to_toml(_set(doc, path, "x" * HUGE_TEXT)).encode(), True
    raise ValueError(kind)


def make_nonregular(path: Path, rng: random.Random) -> str:
    """Replace ``path`` by a directory, a FIFO, a link to ``/dev/zero`` or a dangling link."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()
    r = rng.randrange(4)
    if r == 0:
        path.mkdir()
        (path / "inside.txt").write_text("x")
        return "directory"
    if r == 1:
        os.mkfifo(path)
        return "fifo"
    if r == 2:
        path.symlink_to("/dev/zero")
        return "/dev/zero"
    path.symlink_to(path.parent / "no-such-target")
    return "dangling"


def write_damaged(path: Path, data: bytes) -> None:
    if path.is_symlink() or path.exists():
        path.unlink()
    path.write_bytes(data)


# -------------------------------------------------------------------------- file formats

FILE_KINDS = ("malformed", "huge", "deep", "nonfinite", "wrongtype", "missing", "nonregular")


def _damage(path: Path, doc: Any, rng: random.Random, kind: str, toml: bool = False,
            oversize: int | None = None) -> bool:
    """Damage ``path`` (holding ``doc``) by ``kind``; returns ``may_pass``."""
    if kind == "nonregular":
        make_nonregular(path, rng)
        return False
    if kind == "huge" and oversize is not None and rng.random() < 0.3:
        write_damaged(path, b"")
        with open(path, "r+b") as f:
            f.truncate(oversize + 1)  # sparse: past the size limit, no disk used
        return False
    data, may_pass = (mutate_toml if toml else mutate_json)(doc, rng, kind)
    write_damaged(path, data)
    return may_pass


def gen_level(rng, ctx, kind):
    from navbench.levelio import MAX_LEVEL_BYTES

    p = ctx.proj / "levels" / "tiny.json"
    may = _damage(p, json.loads(p.read_text()), rng, kind, oversize=MAX_LEVEL_BYTES)
    return Case(f"level/{kind}", argv=["sample-tasks", "levels/tiny.json", "--count", "2", "--out", "newtasks"],
                names=("tiny.json",), may_pass=may, outputs=("newtasks/",))


def gen_taskset(rng, ctx, kind):
    from navbench.plan.tasks import check_tasks_on_level, read_task_file

    p = next((ctx.proj / "tasks").glob("tiny-*.json"))
    may = _damage(p, json.loads(p.read_text()), rng, kind)

    def call():
        from navbench.levelio import load_level

        ts = read_task_file(p)
        check_tasks_on_level(load_level(ctx.proj / "levels" / "tiny.json"), ts.tasks, str(p))

    return Case(f"taskset/{kind}", call=call, names=(p.name,), may_pass=may)


def gen_profile(rng, ctx, kind):
    p = ctx.proj / "tiny.toml"
    doc = tomllib.loads(p.read_text())
    _damage(p, doc, rng, kind, toml=True)
    # --executor bogus: a profile that still loads is refused right after, before any work
    return Case(f"profile/{kind}", argv=["run-navigation", "--profile", "tiny.toml", "--map", "true",
                                         "--executor", "bogus"], names=(), may_pass=False)


def gen_intrinsics(rng, ctx, kind):
    p = ctx.root / "tum" / "intrinsics.json"
    may = _damage(p, json.loads(p.read_text()), rng, kind)
    return Case(f"intrinsics/{kind}", argv=["import-views", str(ctx.root / "tum"), "--out", "new.npz"],
                names=("intrinsics.json",), may_pass=may, outputs=("new.npz",))


def _tum_list_damage(rng, path: Path, kind: str) -> bool:
    lines = path.read_text().splitlines()
    k = rng.choice([i for i, ln in enumerate(lines) if ln.strip() and not ln.startswith("#")])
    parts = lines[k].split()
    if kind == "nonregular":
        make_nonregular(path, rng)
        return False
    if kind == "malformed":
        r = rng.randrange(3)
        data = (path.read_bytes()[: rng.randrange(1, 40)] + b"\xff\xfe garbage" if r == 0 else
                bytes(rng.randrange(256) for _ in range(500)) if r == 1 else
                "\n".join(lines[:k] + [" ".join(parts[: max(1, len(parts) - 1)])] + lines[k + 1:]).encode())
        write_damaged(path, data)
        return False
    if kind in ("nonfinite", "wrongtype", "deep"):
        i = rng.randrange(len(parts)) if path.name == "groundtruth.txt" else 0
        parts[i] = (rng.choice(["nan", "inf", "-inf", "1e400"] + (["1e308", "-1e308"] if i else []))
                    if kind == "nonfinite" else
                    rng.choice(["true", "abc", "[1]", "{}", "None", "0x1p3"]) if kind == "wrongtype" else
                    "[" * 5000)
        lines[k] = " ".join(parts)
        write_damaged(path, ("\n".join(lines) + "\n").encode())
        return False
    if kind == "missing":
        del lines[k]
        write_damaged(path, ("\n".join(lines) + "\n").encode())
        return True
    if kind == "huge":
        if rng.random() < 0.5:
            write_damaged(path, (lines[k] + " " + "9" * HUGE_TEXT + "\n").encode())
        else:  # repeated lines: the association may still find the frames
            write_damaged(path, ("\n".join(lines + [lines[k]] * HUGE_LIST) + "\n").encode())
            return True
        return False
    raise ValueError(kind)


def gen_tumlist(rng, ctx, kind):
    name = rng.choice(["rgb.txt", "depth.txt", "groundtruth.txt"])
    may = _tum_list_damage(rng, ctx.root / "tum" / name, kind)
    return Case(f"tum-{name}/{kind}", argv=["import-views", str(ctx.root / "tum"), "--out", "new.npz"],
                names=(name,) if kind != "missing" else (), may_pass=may, outputs=("new.npz",))


def gen_manifest(rng, ctx, kind):
    from navbench.pipeline.cache import ArtifactStore

    stage, key = ctx.info["views_artifact"]
    store = ArtifactStore(ctx.proj / "results" / "cache")
    p = store.path(stage, key) / "manifest.json"
    _damage(p, json.loads(p.read_text()), rng, kind)

    def call():
        store.lookup(stage, key)
        store.ls()
        store.load(stage, key)

    return Case(f"manifest/{kind}", call=call, names=(), may_pass=True, cache_may_change=True)


def gen_ref(rng, ctx, kind):
    from navbench.pipeline.cache import ArtifactStore

    store = ArtifactStore(ctx.proj / "results" / "cache")
    p = store.set_ref("fuzz", [tuple(ctx.info["views_artifact"])])
    _damage(p, json.loads(p.read_text()), rng, kind)
    return Case(f"ref/{kind}", call=lambda: (store.refs(), store.ls()), names=(), may_pass=True)


def _npz_damage(path: Path, rng, kind: str, header_key: str = "header") -> bool:
    import numpy as np

    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(str(arrays[header_key]))
    if kind == "nonregular":
        make_nonregular(path, rng)
        return False
    if kind == "malformed" and rng.random() < 0.6:
        b = path.read_bytes()
        if rng.random() < 0.5:
            write_damaged(path, b[: rng.randrange(len(b))])
            return False
        # bytes overwritten in the middle: may land in array data, which stays readable
        write_damaged(path, b[:100] + bytes(rng.randrange(256) for _ in range(200)) + b[300:])
        return True
    if kind == "wrongtype" and rng.random() < 0.5:
        k = rng.choice([k for k in arrays if k != header_key])
        arrays[k] = rng.choice([np.zeros((2, 2), np.int8), np.array(["a", "b"]), np.zeros(0),
                                np.full(arrays[k].shape, np.nan, np.float64) if arrays[k].dtype.kind == "f"
                                else np.zeros((3,), np.float32)])
        may = False
    elif kind == "nonfinite" and rng.random() < 0.5:
        k = rng.choice([k for k in arrays if k != header_key and arrays[k].dtype.kind == "f"] or [header_key])
        if k != header_key:
            a = arrays[k].copy()
            a.flat[rng.randrange(a.size)] = rng.choice([np.nan, np.inf, -np.inf])
            arrays[k] = a
        may = True
    else:
        text, may = mutate_json(header, rng, kind if kind != "nonregular" else "malformed")
        try:
            arrays[header_key] = np.array(text.decode())
        except UnicodeDecodeError:
            arrays[header_key] = np.frombuffer(text, np.uint8)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **arrays)
    write_damaged(path, tmp.read_bytes())
    tmp.unlink()
    return may


def gen_map(rng, ctx, kind):
    from navbench.worldmodel.base import load_world_model

    p = ctx.proj / "m.npz"
    may = _npz_damage(p, rng, kind)
    return Case(f"map/{kind}", call=lambda: load_world_model(p), names=("m.npz",), may_pass=may)


def gen_views(rng, ctx, kind):
    from navbench.worldmodel.views import load_views

    p = ctx.proj / "v.npz"
    may = _npz_damage(p, rng, kind)
    return Case(f"views/{kind}", call=lambda: load_views(p), names=("v.npz",), may_pass=may)


def gen_houseexpo(rng, ctx, kind):
    p = ctx.proj / "house.json"
    doc = {"verts": [[0, 0], [6, 0], [6, 4], [3, 4], [3, 6], [0, 6]], "bbox": {"min": [0, 0], "max": [6, 6]}}
    p.write_text(json.dumps(doc))
    may = _damage(p, doc, rng, kind)
    if kind == "huge" and rng.random() < 0.5:  # a long outline (the quadratic self-crossing check)
        import numpy as np

        n = rng.randint(2000, 30000)
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
        p.write_text(json.dumps({"verts": np.c_[3 + 2 * np.cos(t), 3 + 2 * np.sin(t)].tolist(),
                                 "bbox": {"min": [0, 0], "max": [6, 6]}}))
        may = False
    return Case(f"houseexpo/{kind}", argv=["make-level", "fuzzhouse", "--seed", "1", "--from-houseexpo",
                                           "house.json"], names=("house.json",), may_pass=may,
                outputs=("levels/fuzzhouse.json",))


FILE_FORMATS: dict[str, Callable] = {
    "level": gen_level, "taskset": gen_taskset, "profile": gen_profile, "intrinsics": gen_intrinsics,
    "tumlist": gen_tumlist, "manifest": gen_manifest, "ref": gen_ref, "map": gen_map,
    "views": gen_views, "houseexpo": gen_houseexpo,
}


# ------------------------------------------------------------------------------- options

BAD_INT = ["abc", "1.5", "nan", "", "1e3", "0x10", "1" + "0" * 40, "-" + "9" * 30]
BAD_FLOAT = ["nan", "NaN", "inf", "-inf", "Infinity", "1e400", "-1e400", "abc", ""]
BAD_CHOICE = ["bogus", "", "../x", "a" * 5000, "FIT", " true"]
BAD_OPTION = ["steps=" + "[" * 5000 + "]" * 5000, "steps=NaN", "steps=Infinity", "steps=1e400",
              "steps=-Infinity", "steps=" + "1" * 5000, "noequals", "=1", "steps=" + "x" * 200_000,
              "steps=" + "{\"a\":" * 3000 + "1" + "}" * 3000]


def _bad_path(rng, ctx) -> tuple[str, str]:
    """A path that is no usable input file: (path, what)."""
    r = rng.randrange(6)
    base = ctx.proj / f"bad{rng.randrange(10**6)}"
    if r == 0:
        base.mkdir()
        return str(base), "directory"
    if r == 1:
        os.mkfifo(str(base) + ".fifo")
        return str(base) + ".fifo", "fifo"
    if r == 2:
        return "/dev/zero", "device"
    if r == 3:
        return str(base) + ".missing", "missing"
    if r == 4:
        p = Path(str(base) + ".json")
        p.write_text("[" * 100_000 + "]" * 100_000)
        return str(p), "deep"
    p = Path(str(base) + ".npz")
    p.write_bytes(bytes(rng.randrange(256) for _ in range(300)))
    return str(p), "garbage"


def _int_bad(lo: int | None) -> list[str]:
    return BAD_INT + ([str(lo - 1), str(lo - 10**6)] if lo is not None else [])


#: command -> (base argv, {option: kind}); kinds: ("int", min), "float", "seed", "choice",
#: "path", "opt", "address", "condition". Every value generated for a kind is invalid for sure,
#: so every case must end in exit 2.
OPTION_TABLE: dict[str, tuple[list[str], dict[str, Any]]] = {
    "sample-tasks": (["sample-tasks", "tiny"], {"--count": ("int", 1), "--seed": "seed", "LEVEL": "path"}),
    "make-level": (["make-level", "fz", "--seed", "1"], {"--size": "float", "--kind": "choice",
                                                          "--from-houseexpo": "path", "--seed": "seed"}),
    "run-navigation": (["run-navigation", "--profile", "tiny.toml", "--map", "true"],
                       {"--tasks": ("int", 1), "--seeds": ("int", 1), "--workers": ("int", 0),
                        "--chunk": ("int", 1), "--executor": "choice", "--address": "address",
                        "--estimators": "choice", "--noise": "choice", "--goal": "choice",
                        "--condition": "condition", "--profile": "path", "--map": "choice"}),
    "track-eval": (["track-eval", "tiny", "--map", "true", "--estimators", "gt"],
                   {"--trajectories": ("int", 1), "--seeds": ("int", 1), "--steps": ("int", 1),
                    "--camera": "choice", "--seed": "seed", "--noise": "choice", "--option": "opt",
                    "--map": "path", "--estimators": "choice"}),
    "localize-eval": (["localize-eval", "tiny", "--map", "true"],
                      {"--queries": ("int", 1), "--camera": "choice", "--changes": "choice",
                       "--seed": "seed", "--option": "opt", "--map": "path"}),
    "import-views": (["import-views", "TUM", "--out", "new.npz"],
                     {o: "float" for o in ("--fx", "--fy", "--cx", "--cy", "--camera-height",
                                           "--depth-scale", "--max-dt", "--max-tilt", "--max-height-dev")}
                     | {"DIRECTORY": "path"}),
    "fit-map": (["fit-map", "tiny", "--profile", "tiny.toml"],
                {"--steps": ("int", 1), "--heldout-every": ("int", 2), "--seed": "seed",
                 "--camera": "choice", "--device": "choice", "--views": "path", "--heldout": "path",
                 "--profile": "path", "--fx": "float"}),
    "track-sequence": (["track-sequence", "TUM", "--map", "m.npz"],
                       {"--option": "opt", "--estimator": "choice", "--odometry": "path",
                        "--seed": "seed", "--fx": "float", "--max-dt": "float", "--map": "path"}),
    "score": (["score"], {"--seed": "seed", "--boot": ("int", 1), "--preset": "choice"}),
    "report": (["report", "--out", "newreport"], {"--boot": ("int", 1), "--trajectories": ("int", 0),
                                                 "--preset": "choice"}),
    "export-trajectories": (["export-trajectories", "newtraj"], {"--dt": "float"}),
    "show-level": (["show-level", "tiny", "--out", "new.png"], {"--dpi": ("int", 20), "NAME": "path"}),
    "collect-views": (["collect-views", "tiny"], {"--count": ("int", 1), "--seed": "seed",
                                                   "--camera": "choice"}),
    "bench": (["bench", "--quick"], {"--seed": "seed", "--repeats": ("int", 1), "--workers": ("int", 0)}),
    "db runs": (["db", "runs"], {"--last": ("int", 1)}),
    "all": (["all", "--profile", "tiny.toml"], {"--workers": ("int", 0), "--executor": "choice",
                                                 "--address": "address", "--condition": "condition",
                                                 "--profile": "path"}),
    "export-views": (["export-views", "v.npz", "newexport"], {"VIEWS": "path"}),
    "level-difficulty": (["level-difficulty", "tiny"], {"--count": ("int", 1), "LEVELS": "path"}),
}


def _positional(argv: list[str], ctx: Ctx) -> list[str]:
    return [str(ctx.root / "tum") if a == "TUM" else a for a in argv]


def gen_option(command: str, option: str):
    base, table = OPTION_TABLE[command]
    kind = table[option]

    def gen(rng, ctx):
        argv = _positional(list(base), ctx)
        names: tuple[str, ...] = ()
        if isinstance(kind, tuple):
            value = rng.choice(_int_bad(kind[1]))
        elif kind == "seed":
            value = rng.choice(_int_bad(0))
        elif kind == "float":
            value = rng.choice(BAD_FLOAT)
        elif kind == "choice":
            value = rng.choice(BAD_CHOICE)
        elif kind == "path":
            value, _what = _bad_path(rng, ctx)
        elif kind == "opt":
            value = rng.choice(BAD_OPTION)
            if command == "track-eval" and "=" in value and not value.startswith("="):
                value = "gt." + value if rng.random() < 0.3 else "ours." + value
        elif kind == "address":
            value = rng.choice(["10.255.255.1:6379", "localhost:1", "ray://nowhere:1", "x"])
        elif kind == "condition":
            value = rng.choice(["bogus", "=", "friction=", "a=b", "x" * 3000 + "=1", "friction=nan"])
        else:
            raise ValueError(kind)
        if option.isupper():  # a positional argument: replace it
            i = {"LEVEL": 1, "DIRECTORY": 1, "NAME": 1, "VIEWS": 1, "LEVELS": 1}[option]
            argv[i] = value
        else:
            argv += [option, value]
        outs = tuple(a for a in ("newtasks/", "new.npz", "newreport/", "newtraj/", "new.png", "tasks/",
                                 "newexport/")
                     if a.rstrip("/") in argv or a == "tasks/")
        return Case(f"option/{command} {option}={value[:24]!r}", argv=argv, names=names,
                    may_pass=False, outputs=outs)

    gen.__name__ = f"option {command} {option}"
    return gen


# ----------------------------------------------------------------------------- the list

def _generators() -> list[tuple[str, Callable]]:
    out = []
    for fmt, g in FILE_FORMATS.items():
        for kind in FILE_KINDS:
            out.append((f"{fmt}/{kind}", (lambda g, kind: lambda rng, ctx: g(rng, ctx, kind))(g, kind)))
    for command, (_base, table) in OPTION_TABLE.items():
        for option in table:
            out.append((f"option/{command} {option}", gen_option(command, option)))
    return out


GENERATORS = _generators()


def cases(n: int, seed: int = 0) -> list[tuple[int, str]]:
    """``(case index, generator name)`` for ``n`` cases: round-robin over :data:`GENERATORS`
    in a seeded order (each covered once in every ``len(GENERATORS)`` cases)."""
    order = list(range(len(GENERATORS)))
    random.Random(seed).shuffle(order)
    return [(k, GENERATORS[order[k % len(order)]][0]) for k in range(n)]


def build(k: int, name: str, ctx: Ctx, seed: int = 0) -> Case:
    """Prepare case ``k`` (generator ``name``) in ``ctx``'s project."""
    gen = dict(GENERATORS)[name]
    return gen(random.Random(f"{seed}:{k}"), ctx)
