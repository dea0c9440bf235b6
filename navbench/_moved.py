"""Old import paths of moved modules, kept working with a :class:`DeprecationWarning`.

The results database, scoring and the report moved out of :mod:`navbench.pipeline` into
:mod:`navbench.results` and :mod:`navbench.report`. Code written against the old paths
(``from navbench.pipeline.db import ResultsDB``) keeps working: a meta-path finder answers an old
name with the module at its new path (the same module object, so ``isinstance`` and monkeypatches
agree) and warns once per name. Nothing new should import an old path.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: old module path -> new module path.
MOVED = {
    "navbench.pipeline.db": "navbench.results.db",
    "navbench.pipeline.db.resume": "navbench.results.db.resume",
    "navbench.pipeline.db.rows": "navbench.results.db.rows",
    "navbench.pipeline.db.schema": "navbench.results.db.schema",
    "navbench.pipeline.db.store": "navbench.results.db.store",
    "navbench.pipeline.score": "navbench.results.score",
    "navbench.pipeline.score_presets": "navbench.results.presets",
    "navbench.pipeline.breakdown": "navbench.results.breakdown",
    "navbench.pipeline.report": "navbench.report.build",
    "navbench.pipeline.report_claim": "navbench.report.claim",
    "navbench.pipeline.report_goals": "navbench.report.goals",
    "navbench.pipeline.report_localize": "navbench.report.localize",
    "navbench.pipeline.report_topviews": "navbench.report.topviews",
    "navbench.pipeline.results_table": "navbench.report.tables",
    "navbench.pipeline.plots": "navbench.report.plots",
    "navbench.pipeline.publish": "navbench.report.publish",
}


class _Alias(importlib.abc.Loader):
    def __init__(self, new: str):
        self.new = new

    def create_module(self, spec):
        module = importlib.import_module(self.new)
        self._spec = module.__spec__  # the import system sets the alias's spec on it next
        return module

    def exec_module(self, module):  # the new module is already executed: restore its own spec
        module.__spec__ = self._spec


class _MovedFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path=None, target=None):
        new = MOVED.get(fullname)
        if new is None:
            return None
        warnings.warn(f"{fullname} moved to {new}; import it from there", DeprecationWarning, stacklevel=2)
        return importlib.util.spec_from_loader(fullname, _Alias(new), is_package=new.endswith(".db"))


def install() -> None:
    """Put the finder on ``sys.meta_path`` once."""
    if not any(isinstance(f, _MovedFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _MovedFinder())
