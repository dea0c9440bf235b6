#!/bin/bash
# A/B of the overlap background's numba threads on 2 cores: old (56efb51: default threads) against
# new (fd58f95: the background on one thread, the command on the cores left while the first level
# is built). Both start the background with the command (2 cores). Otherwise as ab.sh.
# 2500 views and 5000 fit steps a level (the paper's 1:2 proportion, halved), 8 tasks; the
# figure is the first level's build (its foreground stages in the stored breakdown).
export PATH=/work/main/.venv/bin:$PATH COLUMNS=150
ARGS="--profile paper --benchmark-version navbench-5 --workers 2 --set levels=house-1,house-2 --set views.count=2500 --set fit.steps=5000 --set tasks.count=8"
run() {  # clone tag
  local d=/work/ovl/$1/run-$2; rm -rf $d; mkdir -p $d
  cd /work/ovl/$1 && local t=$(date +%s.%N)
  PYTHONPATH=/work/ovl/$1 NAVBENCH_DB=sqlite:///$d/nb.db NAVBENCH_CACHE=$d/cache navbench all $ARGS --report $d/rep > $d/log.txt 2>&1
  local rc=$?; local w=$(python3 -c "import time;print(f'{time.time()-$t:.1f}')")
  echo "$(date -u +%T) $1 $2 rc $rc wall $w load $(cut -d' ' -f1 /proc/loadavg)"
  grep -E "^(verify|collect-views|fit-map|sample-tasks|run-navigation|wall) " $d/log.txt | tr -s ' ' | sed 's/^/   /'
}
run old warm; run new warm
for r in 1 2 3; do
  if [ $((r % 2)) -eq 1 ]; then run old r$r; run new r$r; else run new r$r; run old r$r; fi
done
echo done
