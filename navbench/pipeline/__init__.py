"""Orchestration: stages, their cache, profiles and parallel execution.

* :mod:`navbench.pipeline.cache` — the content-addressed artifact store and ``run_stage``;
* :mod:`navbench.pipeline.stages` — one frozen config dataclass and one function per stage;
* :mod:`navbench.pipeline.profiles` — TOML profiles (``quick``, ``paper``) with CLI overrides;
* :mod:`navbench.pipeline.executor` — local process pool and Ray back ends for episode chunks;
* :mod:`navbench.pipeline.run` — ``run_profile``: a whole profile, the CLI's ``all``.

The results database, scoring and the report live in :mod:`navbench.results` and
:mod:`navbench.report`; their old import paths under ``navbench.pipeline`` still work for one
release with a :class:`DeprecationWarning` (:mod:`navbench._moved`).

This package imports nothing heavy at import time.
"""

from navbench import _moved

_moved.install()
