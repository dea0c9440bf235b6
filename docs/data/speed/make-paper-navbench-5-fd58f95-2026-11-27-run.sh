#!/bin/bash
# Issue 36: `make paper` under navbench-5 with the overlap threads fix (fd58f95), measured whole on the 2-core machine, from an empty
# cache (the numba cache warm, as after `make setup`'s first run), overlap on (the default).
cd /work/paper4/code
export PYTHONPATH=$PWD NUMBA_CACHE_DIR=/work/main/.numba_cache PATH=/work/main/.venv/bin:$PATH
export NAVBENCH_CACHE=/work/paper6/cache
echo "=== start $(date -u +%H:%M:%S) load $(cut -d' ' -f1-3 /proc/loadavg) commit $(git rev-parse --short HEAD) nproc $(nproc)"
/usr/bin/time -v navbench all --profile paper --benchmark-version navbench-5 \
  --db sqlite:////work/paper6/paper6.db --report /work/paper6/report
echo "=== rc $? end $(date -u +%H:%M:%S) load $(cut -d' ' -f1-3 /proc/loadavg)"
