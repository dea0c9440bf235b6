# One device call (issue 36 section 4, 2026-11-27 second loan): the GPU fit against the CPU path on
# 5000 half views (10 000 GPU steps as one CUDA graph each, 1000 CPU-path steps), then the paper
# profile under navbench-5 (texel tables) with the GPU fit on 16 workers, house-1 and house-2, so
# that house-2's views and fit overlap house-1's episodes; cut at the call's limit if need be.
set -o pipefail
T00=$(date +%s)
LIMIT=${LIMIT:-560}
. .whl/setup.sh
export NUMBA_CACHE_DIR=$PWD/.numba_cache COLUMNS=120
left() { echo $(( LIMIT - ($(date +%s) - T00) )); }
{ date -u; nvidia-smi -L; nproc; lscpu | grep -E "Model name|Thread|Core|Socket"; uptime; python3 -c "import torch,numba,numpy;print(torch.__version__,torch.cuda.is_available(),torch.cuda.get_device_name(0),numba.__version__,numpy.__version__)"; } 2>&1 | tee $OUT/env.txt
fit() {  # name, timeout, args...
  local name=$1 to=$2; shift 2; local t=$(date +%s)
  timeout $to $NB fit-map house-1 --profile .whl/gpu-half.toml --json "$@" > $OUT/$name.json 2> /tmp/$name.err
  local rc=$?; echo "$name rc $rc wall $(( $(date +%s)-t )) s"; tail -3 /tmp/$name.err
  python3 -c "import json,sys;m=json.load(open('$OUT/$name.json'));print({k:m.get(k) for k in ('device','device_name','cuda_graph','graph_error','steps','fit_seconds','ms_per_step','depth_mae_m','rgb_l1','slice_precision','slice_recall')})" 2>/dev/null
  return $rc
}
T0=$(date +%s); timeout 60 $NB collect-views house-1 --profile .whl/gpu-half.toml > /tmp/views.log 2>&1; echo "views rc $? wall $(( $(date +%s)-T0 )) s"; tail -2 /tmp/views.log
fit fit-cuda-10000 70 --device cuda; GRC=$?
fit fit-cpu-1000 50 --device cpu --steps 1000
uptime
GRAPH=""; [ $GRC -eq 0 ] || GRAPH="NAVBENCH_CUDA_GRAPH=0"
L=$(( $(left) - 5 )); echo "paper house-1,house-2 under navbench-5: $L s left"; date -u
T0=$(date +%s)
( while sleep 30; do echo "$(date -u +%T) $(cut -d' ' -f1-3 /proc/loadavg)"; done ) > $OUT/load.txt &
env $GRAPH timeout $L $NB all --profile paper --benchmark-version navbench-5 --workers 16 --set levels=house-1,house-2 --set fit.device=cuda > $OUT/paper5.log 2>&1
echo "paper rc $? wall $(( $(date +%s)-T0 )) s (limit $L)"; uptime; date -u
grep -v "━" $OUT/paper5.log | grep -v "^ *\(views\|steps\|ep/s\)…" | tail -70
