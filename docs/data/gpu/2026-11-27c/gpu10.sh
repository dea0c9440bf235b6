# Third loan (2026-11-27, evening): the paper profile under navbench-5 on 16 workers at HEAD (overlap
# background on one numba thread, started after the first level's views), house-1..3 whole (200 tasks,
# 1800 episodes a level), GPU fit; stopped by the call's limit. Reads: first level's build, episodes a
# minute per level, and whether the one-thread background keeps up ("overlap: waited").
set -o pipefail
T00=$(date +%s); LIMIT=${LIMIT:-560}
. .whl/setup.sh
export NUMBA_CACHE_DIR=$PWD/.numba_cache COLUMNS=120 NAVBENCH_CACHE=$PWD/nbcache
{ date -u; nproc; git rev-parse --short HEAD 2>/dev/null; uptime; python3 -c "import torch,numba,numpy;print(torch.__version__,torch.cuda.is_available(),torch.cuda.get_device_name(0),numba.__version__,numpy.__version__)"; } 2>&1 | tee $OUT/env10.txt
( while true; do echo "$(date -u +%H:%M:%S) $(cut -d' ' -f1-3 /proc/loadavg) eps $(ls $NAVBENCH_CACHE/episode 2>/dev/null | wc -l)"; sleep 15; done ) > $OUT/load10.txt 2>&1 &
L=$(( LIMIT - ($(date +%s) - T00) )); echo "$L s left"
T0=$(date +%s)
timeout $L $NB all --profile paper --benchmark-version navbench-5 --workers 16 --set levels=house-1,house-2,house-3 --set fit.device=cuda --db sqlite:///$OUT/paper10.db > $OUT/paper10.log 2>&1
echo "paper rc $? wall $(( $(date +%s)-T0 )) s (limit $L)"; uptime; date -u
grep -v "━" $OUT/paper10.log | tail -40
tail -45 $OUT/load10.txt
