"""Config hashing (the content hash of a frozen dataclass is its cache key) and where the cache is.

``config_hash`` is sha256 over the sorted, compact JSON of a value made only of dataclasses,
dicts, lists/tuples, str, int, float, bool and None. Floats are written with ``repr`` so that a
change in the last bit changes the key.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path
from typing import Any


def to_jsonable(obj: Any) -> Any:
    """Convert dataclasses, tuples and numpy scalars to plain JSON values (recursively)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if hasattr(obj, "item") and callable(obj.item) and getattr(obj, "shape", None) == ():
        return obj.item()  # numpy scalar
    if obj is None or isinstance(obj, (str, int, float, bool)):
        return obj
    raise TypeError(f"cannot hash value of type {type(obj).__name__}")


def canonical_json(obj: Any) -> str:
    """Sorted, compact JSON of ``obj`` (the text that is hashed)."""
    return json.dumps(to_jsonable(obj), sort_keys=True, separators=(",", ":"), allow_nan=False)


def config_hash(obj: Any) -> str:
    """Full sha256 hex digest of ``canonical_json(obj)``."""
    return hashlib.sha256(canonical_json(obj).encode()).hexdigest()


def read_json(path: str | Path, error: type[Exception], missing: str,
              invalid: str = "not valid JSON", finite: bool = False) -> Any:
    """The JSON document in ``path``; raises ``error(missing)`` when there is no such file and
    a one-line ``error("<path>: ...")`` when it is not a regular file or not readable JSON
    (:func:`navbench.safeio.load_json`: bounded size and nesting; ``finite``: NaN and
    infinities refused). ``invalid`` is kept for callers' compatibility."""
    from navbench.safeio import check_regular_file, load_json

    path = Path(path)
    if not path.exists():
        raise error(missing)
    check_regular_file(path, error, "JSON file")  # a directory, FIFO or device: one line
    return load_json(path, error, "JSON file", finite=finite)


#: The stage cache of a project: ``results/cache`` of the working directory...
DEFAULT_CACHE = "results/cache"
#: ... unless this environment variable names another folder (one cache shared by project
#: folders; docs/reference/overrides.md says what is and is not shared).
CACHE_ENV = "NAVBENCH_CACHE"


def default_cache_root() -> Path:
    """``$NAVBENCH_CACHE`` when set, else ``results/cache`` (of the working directory)."""
    import os

    return Path(os.environ.get(CACHE_ENV) or DEFAULT_CACHE).expanduser()
