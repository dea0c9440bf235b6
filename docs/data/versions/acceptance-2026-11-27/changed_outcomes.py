"""Which episodes changed outcome between the two versions' acceptance grids, and why (the
episode's end reason): `python changed_outcomes.py acceptance-1.db acceptance-2.db [LEVEL]`.

Reads the episodes tables directly (sqlite3), pairs by (level, task, noise, estimator, seed) and
prints every pair whose success differs, then counts per (level, estimator, end reason)."""

import collections
import sqlite3
import sys

Q = ("select level, task_id, noise, estimator, seed, success, end_reason, steps, map_key from episodes"
     " where estimator in ('ours', 'no-map', 'dynamics')")


def rows(path):
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as con:
        return {r[:5]: r[5:] for r in con.execute(Q)}


a, b = rows(sys.argv[1]), rows(sys.argv[2])
level = sys.argv[3] if len(sys.argv) > 3 else None
lost = collections.Counter()
won = collections.Counter()
for k in sorted(a):
    if k not in b or a[k][0] == b[k][0] or (level and k[0] != level):
        continue
    (won if b[k][0] else lost)[(k[0], k[3], (b[k] if not b[k][0] else a[k])[1])] += 1
    if level:
        print(k, "A", a[k][:3], "B", b[k][:3])
print("lost under B (level, estimator, B's end reason): count")
for k, n in sorted(lost.items()):
    print(" ", k, n)
print("won under B (level, estimator, A's end reason): count")
for k, n in sorted(won.items()):
    print(" ", k, n)
