set -o pipefail
. .whl/setup.sh
date -u; uptime
T0=$(date +%s)
timeout 560 $NB all --profile .whl/paper-house-1.toml --workers 16 2>&1 | tee $OUT/paper_house1.log | grep -v "━" | tail -80
echo "paper house-1 rc $? wall $(( $(date +%s)-T0 )) s"
