#!/bin/bash
# Paper-camera CPU fits (house-1, the A/B's 2500 cached paper views, 1500 steps): one alone and
# two at once (seeds 1 and 2), each on 2 and on 1 numba thread. Prints ms a step.
export PATH=/work/main/.venv/bin:$PATH PYTHONPATH=/work/ovl/old COLUMNS=150
cd /work/ovl/old
C=/tmp/fp-cache; rm -rf $C; mkdir -p $C; cp -r run-r3/cache/collect-views $C/ 2>/dev/null || true
ls run-r3/cache
fit() { # threads seed out
  NUMBA_NUM_THREADS=$1 NAVBENCH_CACHE=$C navbench fit-map house-1 --profile paper --set views.count=2500 --steps 1500 --seed $2 --force --json > $3 2>/dev/null
  python3 -c "import json;print(round(json.load(open('$3'))['ms_per_step'],2))"
}
for r in 1 2; do for t in 2 1; do
  a=$(fit $t 1 /tmp/fp-a.json)
  fit $t 1 /tmp/fp-b.json > /tmp/fp-b & c=$(fit $t 2 /tmp/fp-c.json); wait
  echo "$(date -u +%T) round $r threads $t: alone $a ms/step; two at once $(cat /tmp/fp-b) $c ms/step; load $(cut -d' ' -f1 /proc/loadavg)"
done; done
