# Issue 36 on a quiet 16-core machine: navbench-2 against navbench-1, agent step and whole
# episodes, in one process (.whl/v2ab.py), on a quick map fitted on the GPU.
set -o pipefail
T00=$(date +%s)
LIMIT=${LIMIT:-270}
. .whl/setup.sh
export NUMBA_CACHE_DIR=$PWD/.numba_cache COLUMNS=120
{ date -u; nvidia-smi -L; nproc; uptime; python3 -c "import torch,numba,numpy;print(torch.__version__,numba.__version__,numpy.__version__)"; } 2>&1 | tee $OUT/env7.txt
T0=$(date +%s)
timeout 90 $NB fit-map house-1 --profile quick --device cuda --json > $OUT/fit7.json 2>/tmp/fit7.err; echo "fit rc $? wall $(( $(date +%s)-T0 )) s"; tail -2 /tmp/fit7.err
MAP=$(python3 -c "import json;print(json.load(open('$OUT/fit7.json'))['path'])")
L=$(( LIMIT - ($(date +%s) - T00) )); echo "v2ab: $L s left"
timeout $L python3 .whl/v2ab.py "$MAP" levels/house-1.json 16 150 16 2 2>&1 | grep -v "━" | tee $OUT/v2ab.log
echo "v2ab rc $? wall $(( $(date +%s)-T00 )) s"; uptime
