"""Image-goal runs of a results database, one block per run: benchmark version, goals localised
(status ``ok``), goals found within 3 cm (the error rounded to the centimetre, as the notebook's
tables), success and mean SPL, then per task ``id:status/error m/confidence/end reason``.

``python docs/data/vizdoom/goal_runs_summary.py DB.sqlite``
"""

import sqlite3, sys
c=sqlite3.connect(sys.argv[1])
for (run, cmd) in c.execute("select id, command from runs order by id").fetchall():
    rows=list(c.execute("select task_id, goal_status, round(goal_err_m,2), round(goal_confidence,3), success, round(spl_term,3), end_reason, benchmark_version from episodes where run_id=? order by task_id",(run,)))
    if not rows: continue
    print(f"run {run}: {cmd}")
    print(f"  version {rows[0][7]}; goals ok {sum(r[1]=='ok' for r in rows)}/{len(rows)}, found within 3 cm {sum(r[2] is not None and r[2]<=0.03 for r in rows)}, success {sum(r[4] for r in rows)}/{len(rows)}, SPL {sum(r[5] for r in rows)/len(rows):.3f}")
    print("  status/err m/conf/end per task:", "; ".join(f"{r[0]}:{r[1]}/{r[2]}/{r[3]}/{r[6]}" for r in rows))
