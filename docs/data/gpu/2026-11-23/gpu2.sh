set -o pipefail
. .whl/setup.sh
date -u; uptime
T0=$(date +%s)
timeout 150 $NB collect-views house-1 --profile .whl/gpu-half.toml 2>&1 | tail -3; echo "collect 5000 half rc $? wall $(( $(date +%s)-T0 )) s"
T0=$(date +%s)
timeout 250 $NB fit-map house-1 --profile .whl/gpu-half.toml --device cuda --json > $OUT/fit_cuda.json 2>$OUT/fit_cuda.err; echo "fit cuda rc $? wall $(( $(date +%s)-T0 )) s"; cat $OUT/fit_cuda.json; tail -3 $OUT/fit_cuda.err
T0=$(date +%s)
timeout 120 $NB fit-map house-1 --profile .whl/gpu-half.toml --device cpu --steps 1000 --json > $OUT/fit_cpu1000.json 2>$OUT/fit_cpu.err; echo "fit cpu 1000 rc $? wall $(( $(date +%s)-T0 )) s"; cat $OUT/fit_cpu1000.json; tail -3 $OUT/fit_cpu.err
