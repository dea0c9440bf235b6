"""The per-step timing components of a navigation episode, named once.

The episode loop (:mod:`navbench.nav.episode`) records one list of milliseconds per component;
the results database stores each component's median as the column ``<name>_ms``
(:class:`navbench.results.db.EpisodeRow`); the report tabulates and plots them in this order.
Every one of them reads the names from here, so adding or renaming a component is one edit
(plus a database column). This module imports nothing: the database and the report use it
without loading the planner (numba) that :mod:`navbench.nav.episode` needs.
"""

from __future__ import annotations

#: Per-step components, in pipeline order: the simulator step, rendering the world model, the
#: estimator update, planning (A*) and the controller decision.
TIMING_KEYS = ("sim", "render", "estimate", "plan", "control")
#: The ``episodes`` columns holding each component's median over steps (milliseconds).
TIMING_COLUMNS = tuple(f"{key}_ms" for key in TIMING_KEYS)
