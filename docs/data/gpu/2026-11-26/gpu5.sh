set -o pipefail
T00=$(date +%s)
. .whl/setup.sh
export NUMBA_CACHE_DIR=$PWD/.numba_cache COLUMNS=120
{ date -u; nvidia-smi -L; nproc; uptime; git log --oneline -1 2>/dev/null; python3 -c "import torch,numba,numpy;print(torch.__version__,torch.cuda.is_available(),torch.cuda.get_device_name(0),numba.__version__,numpy.__version__)"; } 2>&1 | tee $OUT/env.txt
T0=$(date +%s)
timeout 110 python3 -m pytest -q -n 16 -p no:cacheprovider -rfEs tests/worldmodel/test_fit.py tests/worldmodel/test_diffrender.py tests/test_bench.py tests/test_bench_table.py tests/bad_input/test_levels_tasks.py::test_markup_in_paths_is_printed_as_text tests/pipeline/test_golden_rows.py tests/plugins/test_example_plugin.py 2>&1 | tee $OUT/pytest.log | tail -15
echo "pytest rc $? wall $(( $(date +%s)-T0 )) s"
LEFT=$(( 575 - ($(date +%s)-T00) ))
date -u; uptime
T0=$(date +%s)
timeout $LEFT $NB all --profile .whl/paper-house-1.toml --workers 16 > $OUT/paper_house1.log 2>&1
echo "paper house-1 rc $? wall $(( $(date +%s)-T0 )) s (limit $LEFT)"; uptime
grep -v "━" $OUT/paper_house1.log | tail -70
