"""Size and load time of a views directory, uncompressed vs ``compress=True`` (issue 17).

    python docs/data/speed/views_storage.py [--count 2000] [--camera half] [--repeats 5]

Collects ``--count`` views of house-1 (seed 0), writes them both ways into a temporary
directory, then alternates reading each back (``load_views`` and every byte of every array,
through :func:`navbench.worldmodel.views.views_content_hash`) ``--repeats`` times. Prints the
size on disk, the median write and read seconds, and whether both read back bit-identical
(equal content hashes). The files are in the page cache when read: this times the
decompression, not the disk.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path


def size(path: Path) -> int:
    return sum(f.stat().st_size for f in path.iterdir())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=2000, choices=range(1, 20001), metavar="1..20000")
    ap.add_argument("--camera", default="half", choices=("half", "paper"))
    ap.add_argument("--repeats", type=int, default=5, choices=range(1, 101), metavar="1..100")
    a = ap.parse_args()
    from navbench.geometry import CAMERAS
    from navbench.levelio import resolve_level
    from navbench.worldmodel.views import collect_views, load_views, save_views, views_content_hash

    views = collect_views(resolve_level("house-1"), a.count, CAMERAS[a.camera], seed=0)
    want = views_content_hash(views)
    with tempfile.TemporaryDirectory() as tmp:
        paths = {"npy": Path(tmp) / "plain", "compressed": Path(tmp) / "compressed"}
        write = {}
        for name, p in paths.items():
            t0 = time.perf_counter()
            save_views(views, p, compress=name == "compressed")
            write[name] = time.perf_counter() - t0
        read = {name: [] for name in paths}
        same = True
        for rep in range(a.repeats):
            for name in (list(paths) if rep % 2 == 0 else list(paths)[::-1]):
                t0 = time.perf_counter()
                h = views_content_hash(load_views(paths[name]))
                read[name].append(time.perf_counter() - t0)
                same &= h == want
        print(f"{a.count} {a.camera} views, {a.repeats} reads each, load {os.getloadavg()[0]:.2f}")
        base = size(paths["npy"])
        for name, p in paths.items():
            s = size(p)
            print(f"{name:<11} {s / 1e6:8.1f} MB ({s / base:.3f}x)  write {write[name]:6.2f} s  "
                  f"read + hash median {statistics.median(read[name]):6.2f} s")
        print(f"bit-identical read back (content hashes equal): {same}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
