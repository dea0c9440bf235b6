"""Stages, their cache, profiles, parallel execution, the results database, scoring and reports.

* :mod:`navbench.pipeline.cache` — the content-addressed artifact store and ``run_stage``;
* :mod:`navbench.pipeline.stages` — one frozen config dataclass and one function per stage;
* :mod:`navbench.pipeline.profiles` — TOML profiles (``quick``, ``paper``) with CLI overrides;
* :mod:`navbench.pipeline.executor` — local process pool and Ray back ends for episode chunks;
* :mod:`navbench.pipeline.db`, :mod:`~navbench.pipeline.score`, :mod:`~navbench.pipeline.report`
  — the results database, score tables and the HTML report.

This package imports nothing heavy at import time.
"""
