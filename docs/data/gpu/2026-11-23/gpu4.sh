set -o pipefail
. .whl/setup.sh
date -u; uptime
T0=$(date +%s)
COLUMNS=120 timeout 330 $NB all --profile .whl/paper-slice-60.toml --workers 16 > $OUT/slice60.log 2>&1
echo "slice60 rc $? wall $(( $(date +%s)-T0 )) s"
grep -v "━" $OUT/slice60.log | tail -60
cp results/navbench.db $OUT/slice60.db 2>/dev/null
