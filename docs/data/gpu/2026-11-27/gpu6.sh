# One device call (issue 36 section 4): CUDA tests of the device fit path, the 10 000-step fit on
# 5000 half views on the GPU (graph), 3000 steps of the CPU path and 1000 eager GPU steps,
# then the paper profile on house-1 with the GPU fit on 16 workers, until the call's limit.
set -o pipefail
T00=$(date +%s)
LIMIT=${LIMIT:-585}
. .whl/setup.sh
export NUMBA_CACHE_DIR=$PWD/.numba_cache COLUMNS=120
left() { echo $(( LIMIT - ($(date +%s) - T00) )); }
{ date -u; nvidia-smi -L; nproc; uptime; git log --oneline -1 2>/dev/null; python3 -c "import torch,numba,numpy;print(torch.__version__,torch.cuda.is_available(),torch.cuda.get_device_name(0),numba.__version__,numpy.__version__)"; } 2>&1 | tee $OUT/env.txt
T0=$(date +%s)
timeout 80 python3 -m pytest -q -n 8 -p no:cacheprovider -rfEs tests/worldmodel/test_fit_device.py tests/worldmodel/test_fit.py -k 'cuda or graph' 2>&1 | tee $OUT/pytest.log | tail -8
echo "pytest rc $? wall $(( $(date +%s)-T0 )) s"
fit() {  # name, timeout, args...
  local name=$1 to=$2; shift 2; local t=$(date +%s)
  timeout $to $NB fit-map house-1 --profile .whl/gpu-half.toml --json "$@" > $OUT/$name.json 2> /tmp/$name.err
  local rc=$?; echo "$name rc $rc wall $(( $(date +%s)-t )) s"; tail -3 /tmp/$name.err
  python3 -c "import json,sys;m=json.load(open('$OUT/$name.json'));print({k:m.get(k) for k in ('device','device_name','cuda_graph','graph_error','steps','fit_seconds','ms_per_step','depth_mae_m','rgb_l1','slice_precision','slice_recall','final_loss')})" 2>/dev/null
  return $rc
}
# the views first (cached: 5000 + 200 half views), timed apart from the fits
T0=$(date +%s); timeout 120 $NB collect-views house-1 --profile .whl/gpu-half.toml > /tmp/views.log 2>&1; echo "views rc $? wall $(( $(date +%s)-T0 )) s"
fit fit-cuda-10000 200 --device cuda; GRC=$?
NAVBENCH_CUDA_GRAPH=0 fit fit-cuda-eager-1000 90 --device cuda --steps 1000
fit fit-cpu-3000 90 --device cpu --steps 3000
uptime
GRAPH=""; [ $GRC -eq 0 ] || GRAPH="NAVBENCH_CUDA_GRAPH=0"
L=$(left); echo "paper house-1: $L s left"; date -u
T0=$(date +%s)
env $GRAPH timeout $L $NB all --profile paper --workers 16 --set levels=house-1 --set fit.device=cuda > $OUT/paper_house1.log 2>&1
echo "paper house-1 rc $? wall $(( $(date +%s)-T0 )) s (limit $L)"; uptime
grep -v "━" $OUT/paper_house1.log | tail -60
