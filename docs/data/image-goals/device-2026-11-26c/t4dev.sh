# Table 4 at size, house-4 on the device machine; episode artifacts come back as tar parts
T00=$(date +%s); DEADLINE=${DEADLINE:-480}
. .whl/setup.sh
export NUMBA_CACHE_DIR=$PWD/.numba_cache COLUMNS=120
{ date -u; nproc; uptime; python3 -c "import numba,numpy;print(numba.__version__,numpy.__version__)"; } 2>&1 | tee -a $OUT/env.txt
DB=sqlite:///$OUT/dev4.db
for a in full gt-stopper no-goal no-explore; do
  LEFT=$(( DEADLINE - ($(date +%s)-T00) )); [ $LEFT -lt 20 ] && break
  T0=$(date +%s)
  timeout $LEFT $NB run-navigation house-4 --profile imagenav-unknown-quick --tasks 100 --map online --online-ablation $a --workers 16 --db $DB 2>&1 | grep -v "━" >> $OUT/runs.log
  rc=${PIPESTATUS[0]}; echo "house-4 $a rc $rc wall $(( $(date +%s)-T0 )) s at $(( $(date +%s)-T00 )) s; $(uptime)" | tee -a $OUT/times.txt
done
n=$(ls results/cache/episode | wc -l); echo "episode artifacts: $n" | tee -a $OUT/times.txt
tar cf - -C results/cache episode | split -b 15M - $OUT/ep.tar.
ls -la $OUT
