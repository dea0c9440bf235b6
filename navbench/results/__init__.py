"""The results side: what navbench knows after a run, and how it is scored.

It owns the results database (:mod:`navbench.results.db`: runs, levels, maps, task sets,
episodes, tracking, localisation and bench rows), the score tables and paired statistics of the
stored episodes (:mod:`navbench.results.score`), the scoring presets applied to stored rows
(:mod:`navbench.results.presets`; the rules themselves are array math in
:mod:`navbench.nav.presets`), the labels of run settings (:mod:`navbench.results.labels`) and where
a run's time went (:mod:`navbench.results.breakdown`).

It reads rows and writes rows; it never runs a stage, draws a figure or imports
:mod:`navbench.pipeline` (a layering test checks). This package imports nothing heavy at import
time.
"""
