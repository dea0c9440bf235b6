"""The HTML report and its figures, drawn from the results database.

It owns the report document (:mod:`navbench.report.build`: ``build_report``), its sections (the
paper's claim :mod:`~navbench.report.claim`, image goals :mod:`~navbench.report.goals`,
localisation :mod:`~navbench.report.localize`, unknown-house top views
:mod:`~navbench.report.topviews`), the Markdown results table (:mod:`~navbench.report.tables`),
the paper's figures as matplotlib plots (:mod:`~navbench.report.plots`) and publishing a report
folder without overwriting what navbench did not write (:mod:`~navbench.report.publish`).

It reads :mod:`navbench.results` and is handed trajectories and maps through two callables
(:mod:`navbench.pipeline.loaders` builds them from the stage cache); it never imports
:mod:`navbench.pipeline` (a layering test checks). This package imports nothing heavy at import
time.
"""
