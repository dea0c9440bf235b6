#!/bin/bash
# Issue 36: `make paper` (navbench all --profile paper; navbench-5 is the default since 6395e24) measured whole on the
# 2-core machine, from an empty stage cache (the numba cache warm, as after `make setup`'s first run), nothing beside it.
cd /work/paper7/code
export PYTHONPATH=$PWD NUMBA_CACHE_DIR=/work/main/.numba_cache PATH=/work/main/.venv/bin:$PATH
export NAVBENCH_CACHE=/work/paper7/cache
echo "=== start $(date -u +%H:%M:%S) load $(cut -d' ' -f1-3 /proc/loadavg) commit $(git rev-parse --short HEAD) nproc $(nproc)"
/usr/bin/time -v navbench all --profile paper --db sqlite:////work/paper7/paper7.db --report /work/paper7/report
echo "=== rc $? end $(date -u +%H:%M:%S) load $(cut -d' ' -f1-3 /proc/loadavg)"
