"""Artifact files of the stage cache: their format versions, their file names, and the episode
record's on-disk form.

Every stage writes its files under these names inside its artifact directory (see
:class:`navbench.pipeline.cache.ArtifactStore`); readers (the report, the worker, the CLI's
``cache`` and ``report`` commands) take the names from here, so one place says what an artifact
holds. Bumping a stage's :data:`FORMAT` version invalidates that stage's cache.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from navbench.config import to_jsonable


#: Artifact format versions: bump one to invalidate that stage's cache. score 5 (issues 15, 16):
#: score.csv gained conditions, goal, preset, soft_spl, final_dist_m; by_difficulty.csv beside it.
FORMAT = {"make-level": 1, "collect-views": 1, "fit-map": 1, "true-map": 1, "sample-tasks": 1,
          "episode": 1, "score": 5, "report": 5, "verify": 1, "track-eval": 1,
          "import-views": 1, "localize-bank": 1, "localize-eval": 2, "image-goals": 1,
          "health-calibration": 1}


VERIFY_FILE = "verified.json"


VIEWS_FILE = "views"   # a directory of .npy files (memory-mapped on load)


MAP_FILE = "map.npz"


METRICS_FILE = "metrics.json"


TASKS_FILE = "tasks.json"


TRAJ_FILE = "episode.npz"


SCORE_FILE = "score.csv"
PAIRED_FILE = "paired_differences.csv"  # beside score.csv: the paper's claim (ours - others)


REPORT_INDEX = "index.html"


def _sha256_text(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def save_record(record: Any, path: Path) -> None:
    """Write a dataclass episode record to ``path`` (compressed npz): arrays as arrays, dicts of
    arrays (timings) as ``name/key`` arrays, everything else as JSON in ``__meta__``."""
    arrays: dict[str, np.ndarray] = {}
    meta: dict[str, Any] = {}
    for f in dataclasses.fields(record):
        v = getattr(record, f.name)
        if isinstance(v, np.ndarray):
            arrays[f.name] = v
        elif isinstance(v, dict) and v and all(isinstance(x, np.ndarray) for x in v.values()):
            for k, x in v.items():
                arrays[f"{f.name}/{k}"] = x
            meta.setdefault("__dicts__", []).append(f.name)
        else:
            meta[f.name] = to_jsonable(v)
    arrays["__meta__"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def load_record(path: Path, cls: type | None = None) -> Any:
    """Read a record written by :func:`save_record` (as ``cls``, default EpisodeRecord)."""
    if cls is None:
        from navbench.nav.episode import EpisodeRecord as cls  # noqa: N813
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(bytes(z["__meta__"]).decode())
        dict_fields = set(meta.pop("__dicts__", []))
        kw: dict[str, Any] = dict(meta)
        for name in z.files:
            if name == "__meta__":
                continue
            if "/" in name and name.split("/", 1)[0] in dict_fields:
                top, k = name.split("/", 1)
                kw.setdefault(top, {})[k] = z[name]
            else:
                kw[name] = z[name]
    names = {f.name for f in dataclasses.fields(cls)}
    for f in dataclasses.fields(cls):
        if f.name not in kw and f.name in dict_fields:
            kw[f.name] = {}
    return cls(**{k: v for k, v in kw.items() if k in names})


STUDY_FILE = "study.npz"


def save_study(results: dict[str, Any], path: Path) -> None:
    """Write a tracking study's results (:func:`navbench.track.study.run_tracking_study`: nested
    dicts whose leaves are arrays or JSON values) to ``path`` as compressed npz: arrays under
    their ``a/b/c`` key paths, every other leaf as JSON in ``__meta__``."""
    arrays: dict[str, np.ndarray] = {}
    meta: dict[str, Any] = {}

    def walk(obj: dict, prefix: str) -> None:
        for k, v in obj.items():
            if "/" in str(k):
                raise ValueError(f"study key {k!r} contains '/'")
            key = f"{prefix}{k}"
            if isinstance(v, np.ndarray):
                arrays[key] = v
            elif isinstance(v, dict) and v and any(isinstance(x, (np.ndarray, dict)) for x in v.values()):
                walk(v, key + "/")
            else:
                meta[key] = to_jsonable(v)

    walk(results, "")
    arrays["__meta__"] = np.frombuffer(json.dumps(meta, sort_keys=True).encode(), dtype=np.uint8)
    with open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def load_study(path: Path) -> dict[str, Any]:
    """Read what :func:`save_study` wrote, as the same nested dict."""
    out: dict[str, Any] = {}

    def put(key: str, value: Any) -> None:
        *parents, leaf = key.split("/")
        node = out
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = value

    with np.load(path, allow_pickle=False) as z:
        for key, value in json.loads(bytes(z["__meta__"]).decode()).items():
            put(key, value)
        for name in z.files:
            if name != "__meta__":
                put(name, z[name])
    return out
