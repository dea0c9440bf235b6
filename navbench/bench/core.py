"""The benchmark's building blocks: the paper's figures, timing statistics, the speed targets'
type, the configuration and the result row (:class:`Metric`), and the timing loop every
``time_*`` function of :mod:`navbench.bench.timers` uses."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable, NamedTuple

import numpy as np

from navbench.errors import ConfigError
# the paper's speed figures live with its other figures (the report reads them too)
from navbench.paper import PAPER_FIGURES, PAPER_HARDWARE  # noqa: F401


#: The paper's Monte-Carlo batch of the map fit: 25 images x 200 pixels (appendix A).
FIT_BATCH = (25, 200)
#: Pixels per step of the paper's trackers (appendix C).
TRACK_PIXELS = 1000
#: The paper's fit length, for the extrapolated fit time.
FIT_STEPS = 10_000
#: The paper's ray sampling for fitting (appendix A): n = 200 samples, n * Delta = 20 m.
RAY_SAMPLES = 200
RAY_STEP = 20.0 / RAY_SAMPLES
#: Adam steps of one emission update (paper) and of the quick benchmark's shortened update.
EMISSION_STEPS = 100
QUICK_EMISSION_STEPS = 10


class Stats(NamedTuple):
    """Summary of a timing list: count, median, quartiles (numpy's linear interpolation), range."""

    n: int
    median: float
    q1: float
    q3: float
    min: float
    max: float

    @property
    def iqr(self) -> float:
        return self.q3 - self.q1


def stats(values) -> Stats:
    """:class:`Stats` of ``values``; all-NaN fields when there are none."""
    a = np.asarray(list(values), dtype=np.float64)
    if a.size == 0:
        nan = math.nan
        return Stats(0, nan, nan, nan, nan, nan)
    q1, med, q3 = np.percentile(a, [25, 50, 75])
    return Stats(int(a.size), float(med), float(q1), float(q3), float(a.min()), float(a.max()))


@dataclass(frozen=True)
class Target:
    """A speed target of issue #7: ``key`` compared with ``threshold`` by ``op`` (``<=``/``>=``)."""

    key: str
    op: str
    threshold: float
    label: str

    def check(self, value: float | None) -> bool | None:
        if value is None or not math.isfinite(value):
            return None
        return value <= self.threshold if self.op == "<=" else value >= self.threshold


# ---------------------------------------------------------------------------------- helpers

def timed_loop(call: Callable[[int], float], repeats: int, warmup: int = 1,
               budget_s: float | None = None) -> list[float]:
    """Run ``call(k)`` ``warmup`` times untimed, then up to ``repeats`` times; ``call`` returns
    the milliseconds of the part it times (its set-up stays outside). Stops early once
    ``budget_s`` seconds have passed and ``min(3, repeats)`` repeats are done."""
    for k in range(warmup):
        call(k)
    out: list[float] = []
    t_start = time.perf_counter()
    for k in range(repeats):
        out.append(float(call(warmup + k)))
        if budget_s is not None and len(out) >= min(3, repeats) and \
                time.perf_counter() - t_start > budget_s:
            break
    return out


def _ms(fn: Callable[[], Any]) -> float:
    t0 = time.perf_counter()
    fn()
    return 1000.0 * (time.perf_counter() - t0)


def _torch_sync(device: str) -> None:
    if device.startswith("cuda"):
        import torch

        torch.cuda.synchronize()


# ---------------------------------------------------------------------------------- config and rows

@dataclass(frozen=True)
class BenchConfig:
    """What :func:`~navbench.bench.run.run_bench` measures and how long it may take.

    ``repeats``: timed repeats per measurement (``None``: 5 with ``quick``, 20 otherwise);
    ``budget_s``: seconds after which a measurement stops repeating (once it has 3 repeats);
    ``workers``: local processes of the end-to-end measurement (0: the CPU count);
    ``e2e_tasks``: navigation tasks of the end-to-end measurement (``None``: 2 quick, 6 default),
    run with ``e2e_estimators`` (``None``: ``ours`` quick, ``ours, no-map, dynamics`` default).
    """

    level: str = "house-1"
    quick: bool = False
    repeats: int | None = None
    seed: int = 0
    budget_s: float | None = None
    workers: int = 0
    e2e_tasks: int | None = None
    e2e_estimators: tuple[str, ...] | None = None
    cache_root: str = "results/cache"
    map_path: str | None = None  # a voxel map file instead of the cache's newest fit (runs compare)
    root: str = "."  # project root: levels are read from ROOT/levels/NAME.json
    cuda: bool | None = None  # None: whenever torch sees a CUDA device

    def __post_init__(self):
        if self.repeats is not None and self.repeats < 1:
            raise ConfigError(f"repeats must be >= 1, got {self.repeats}")
        if self.workers < 0:
            raise ConfigError(f"workers must be >= 0, got {self.workers}")
        if self.e2e_tasks is not None and self.e2e_tasks < 0:
            raise ConfigError(f"e2e tasks must be >= 0, got {self.e2e_tasks}")

    @property
    def n(self) -> int:
        return self.repeats if self.repeats is not None else (5 if self.quick else 20)

    @property
    def budget(self) -> float:
        return self.budget_s if self.budget_s is not None else (2.0 if self.quick else 12.0)


@dataclass
class Metric:
    """One row of the benchmark: ``key``, what it is, its unit, its timing statistics (or a
    derived ``value``), the device, the paper's figure to compare with and a note."""

    key: str
    group: str
    label: str
    unit: str
    value: float | None
    stats: Stats | None = None
    device: str = "cpu"
    paper: float | None = None
    note: str = ""

