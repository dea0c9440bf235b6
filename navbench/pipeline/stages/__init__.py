"""The pipeline's stages: one frozen config dataclass and one function per stage, one module each.

make-level -> collect-views -> fit-map -> sample-tasks -> run-navigation -> score -> report

Every stage function takes a :class:`StageContext` (the artifact store, the results database, a
log and progress callbacks, the ``force`` set), its config and the references of its inputs, and
returns a reference (stage, key, path) to its verified artifact. Keys are computed before any
work (:func:`navbench.pipeline.cache.run_stage`), so a cached stage costs one checksum pass.
Stages never build SQL or ad-hoc paths: artifacts live in the store under the names of
:mod:`navbench.pipeline.artifacts`, rows go through :class:`navbench.results.db.ResultsDB`.
Heavy work and torch are imported inside the compute functions only: a fully cached pipeline
never loads torch (resolving the FitConfig defaults for the fit-map key imports the world-model
module, which brings numba) and takes about a second.

Keys of committed, human-readable inputs are content hashes: a level's key is the sha256 of its
``levels/NAME.json`` text, a task set's key the sha256 of its task file text (whether the file
is committed under ``tasks/`` or sampled into the cache), so generating a file and committing it
leaves every downstream key unchanged.

=====================  ==========================================================
module                 holds
=====================  ==========================================================
``context``            :class:`StageContext`, :class:`Ref`, :func:`verified`
``level``              make-level (:class:`LevelConfig`)
``views``              collect-views (:class:`ViewsConfig`)
``maps``               fit-map (:class:`FitMapConfig`), true-map (:class:`TrueMapConfig`),
                       :func:`resolve_map` (a map file or a map key)
``imported``           views from outside: :func:`resolve_views` (a views file, a TUM RGB-D
                       directory or a views key), import-views (:func:`store_views_stage`),
                       fit-map of given views without a level (:class:`FitViewsConfig`)
``tasks``              sample-tasks (:class:`TasksConfig`)
``inputs``             a profile's per-level inputs (:class:`LevelInputs`)
``grid``               the navigation grid, seeds and chunks (:class:`NavigationConfig`)
``navigation``         run-navigation (the parent loop; workers: :mod:`navbench.pipeline.worker`)
``score``, ``report``  the score table and the HTML report of a set of cells
``track_eval``         the tracking study (appendix E) on a fitted, true or given map
``health``             health-calibration: a map's own health-test threshold
                       (:class:`HealthCalibrationConfig`, ``health_min_inliers = "auto"``)
=====================  ==========================================================

This package re-exports each module's public names, so ``from navbench.pipeline.stages import
fit_map_stage`` works; modules inside it import from their siblings, never from here.
"""

from navbench.pipeline.stages.context import Ref, StageContext, verified
from navbench.pipeline.stages.grid import (ChunkSpec, Cell, EpisodeJob, NavigationConfig, build_episode_config,
                                           chunk_jobs, episode_key, episode_seeds, make_cells, plan_jobs,
                                           resolved_episode_config)
from navbench.pipeline.stages.imported import (FitViewsConfig, ImportOptions, fit_views_stage, resolve_views,
                                               store_views_stage)
from navbench.pipeline.stages.health import (HealthCalibrationConfig, calibration_views,
                                             health_calibration_stage, study_health_thresholds)
from navbench.pipeline.stages.inputs import LevelInputs, build_level_inputs, fit_map_for_profile
from navbench.pipeline.stages.level import LevelConfig, load_level_ref, make_level_stage
from navbench.pipeline.stages.maps import (MAP_METRIC_KEYS, FitMapConfig, TrueMapConfig, fit_map_stage,
                                           resolve_map, true_map_stage)
from navbench.pipeline.stages.navigation import NavigationSummary, run_navigation_stage
from navbench.pipeline.stages.report import report_stage
from navbench.pipeline.stages.score import episodes_state_key, score_stage
from navbench.pipeline.stages.track_eval import StudyMap, study_level, study_map, track_eval_stage
from navbench.pipeline.stages.tasks import TasksConfig, committed_task_file, sample_tasks_stage
from navbench.pipeline.stages.views import ViewsConfig, collect_views_stage

__all__ = [
    "Cell", "ChunkSpec", "EpisodeJob", "FitMapConfig", "LevelConfig", "LevelInputs", "MAP_METRIC_KEYS",
    "NavigationConfig", "NavigationSummary", "Ref", "StageContext", "TasksConfig", "TrueMapConfig",
    "StudyMap", "ViewsConfig", "build_episode_config", "build_level_inputs", "chunk_jobs", "collect_views_stage",
    "committed_task_file", "episode_key", "episode_seeds", "episodes_state_key", "fit_map_for_profile",
    "fit_map_stage", "load_level_ref", "make_cells", "make_level_stage", "plan_jobs", "report_stage",
    "resolved_episode_config", "run_navigation_stage", "sample_tasks_stage", "score_stage",
    "study_level", "study_map", "track_eval_stage", "true_map_stage", "verified",
    "FitViewsConfig", "ImportOptions", "fit_views_stage", "resolve_map", "resolve_views", "store_views_stage",
    "HealthCalibrationConfig", "calibration_views", "health_calibration_stage", "study_health_thresholds",
]
