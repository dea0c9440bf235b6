# Second call (2026-11-27): the overlap's start moved after the first level's views; the paper
# profile under navbench-5, GPU fit, 16 workers, house-1 and house-2 with 30 tasks each (270
# episodes a level), to time the first level's build with the background beside its fit only.
set -o pipefail
T00=$(date +%s); LIMIT=${LIMIT:-190}
. .whl/setup.sh
export NUMBA_CACHE_DIR=$PWD/.numba_cache COLUMNS=120
{ date -u; git log --oneline -1 2>/dev/null; uptime; } 2>&1 | tee $OUT/env9.txt
L=$(( LIMIT - ($(date +%s) - T00) )); echo "$L s left"
T0=$(date +%s)
timeout $L $NB all --profile paper --benchmark-version navbench-5 --workers 16 --set levels=house-1,house-2 --set fit.device=cuda --set tasks.count=30 > $OUT/paper5b.log 2>&1
echo "paper rc $? wall $(( $(date +%s)-T0 )) s (limit $L)"; uptime; date -u
grep -v "━" $OUT/paper5b.log | grep -v "│\|┃\|─\|═" | tail -60
