set -o pipefail
. .whl/setup.sh
{ date -u; nvidia-smi -L; nproc; uptime; python3 -c "import torch,numba,numpy;print(torch.__version__,torch.cuda.is_available(),torch.cuda.get_device_name(0),numba.__version__,numpy.__version__)"; } 2>&1 | tee $OUT/env.txt
T0=$(date +%s)
timeout 290 python3 -m pytest -q -n 16 tests -p no:cacheprovider 2>&1 | tee $OUT/pytest.log | tail -45
echo "pytest rc $? wall $(( $(date +%s)-T0 )) s"
T0=$(date +%s)
timeout 230 $NB bench --json > $OUT/bench.json 2>$OUT/bench.err; echo "bench rc $? wall $(( $(date +%s)-T0 )) s"; tail -5 $OUT/bench.err
python3 - <<'PY'
import json, os
try:
    d = json.load(open(os.environ["OUT"] + "/bench.json"))
except Exception as e:
    print("no bench json", e); raise SystemExit
for k in sorted(d):
    if isinstance(d[k], (int, float, str)) and k not in ("notes",):
        print(k, d[k])
PY
