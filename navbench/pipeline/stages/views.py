"""collect-views: pose-labelled RGB-D views of a level, sampled in free space (the world model's
training and held-out data)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from navbench.errors import ConfigError
from navbench.geometry import CAMERA_NAMES
from navbench.pipeline.artifacts import VIEWS_FILE
from navbench.pipeline.stages.context import Ref, StageContext
from navbench.pipeline.stages.level import load_level_ref


@dataclass(frozen=True)
class ViewsConfig:
    """collect-views: ``count`` pose-labelled RGB-D views sampled uniformly in free space with
    ``camera`` (``half``: 160x120, ``paper``: 320x240) from pose sampling ``seed``; ``texture``:
    the camera's texture mode (:mod:`navbench.sim.texels`), left out of the key at its default
    ``procedural`` (:func:`views_key_config`), so the views stored before it existed keep their
    keys; rendered by simulator ``sim`` (:mod:`navbench.sim.backends`; on ``vizdoom`` each view
    is labelled with the pose the engine shows, and its projection is the engine's; keyed only
    when it is not pymunk)."""

    count: int
    camera: str = "half"
    seed: int = 0
    texture: str = "procedural"
    sim: str = "pymunk"

    def __post_init__(self):
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count < 1:
            raise ConfigError(f"view count must be a whole number >= 1, got {self.count!r}")
        if self.camera not in CAMERA_NAMES:
            raise ConfigError(f"unknown camera {self.camera!r}; choose {' or '.join(CAMERA_NAMES)}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ConfigError(f"views seed must be a whole number >= 0, got {self.seed!r}")
        from navbench.sim.backends import check_sim
        from navbench.sim.texels import check_texture

        check_texture(self.texture, "views texture")
        check_sim(self.sim, "views sim")

    def key_config(self) -> dict:
        """The config as hashed into the collect-views key (:func:`views_key_config`)."""
        return views_key_config(self)

    def check_memory(self, what: str = "collect-views") -> None:
        """Refuse (ConfigError naming ``what``) a collection whose images do not fit in the
        available memory: :func:`navbench.worldmodel.views.check_views_memory`."""
        from navbench.geometry import camera_by_name
        from navbench.worldmodel.views import check_views_memory

        check_views_memory(self.count, camera_by_name(self.camera), what)


def views_key_config(cfg: ViewsConfig) -> dict:
    """What the collect-views key hashes: the config's fields, ``texture`` only when it is not
    the default ``procedural``, ``sim`` only when it is not the reference simulator
    (:func:`navbench.benchmark.sim_key_part`): the keys of views stored before either setting
    existed stay valid."""
    from navbench.benchmark import sim_key_part
    from navbench.config import to_jsonable

    out = to_jsonable(cfg)
    if out.get("texture") == "procedural":
        del out["texture"]
    del out["sim"]
    return {**out, **sim_key_part(cfg.sim)}


def collect_views_stage(ctx: StageContext, level: Ref, cfg: ViewsConfig) -> Ref:
    """Collect views of ``level`` into the cache (the ``views/`` directory of
    :func:`navbench.worldmodel.views.save_views`)."""

    def compute(d: Path) -> None:
        from navbench.geometry import camera_by_name
        from navbench.worldmodel.views import check_views_disk, collect_views, save_views

        # before any rendering: the memory the views need (collect_views checks it again for
        # library callers) and the disk space they are saved to
        cfg.check_memory(f"collect-views ({level.name})")
        check_views_disk(cfg.count, camera_by_name(cfg.camera), d, f"collect-views ({level.name})")
        update = ctx.progress(f"views {level.name} (seed {cfg.seed})", cfg.count)
        if cfg.sim == "pymunk":
            views = collect_views(load_level_ref(level), cfg.count, camera_by_name(cfg.camera), cfg.seed,
                                  progress=update, texture=cfg.texture)
        else:
            views = _engine_views(load_level_ref(level), cfg, update)
        save_views(views, d / VIEWS_FILE, compress=True)  # depth and valid losslessly compressed

    path, key, cached = ctx.run("collect-views", views_key_config(cfg), {"level": level.key}, compute)
    return Ref("collect-views", key, path / VIEWS_FILE, cached, level.name)


def _engine_views(level, cfg: ViewsConfig, update):
    """:func:`~navbench.worldmodel.views.collect_views` with the frames of simulator ``cfg.sim``:
    the same sampled poses, each view labelled with the pose the engine shows and the engine's
    projection as the views' intrinsics."""
    import dataclasses

    import numpy as np

    from navbench.geometry import CAMERA_HEIGHT, camera_by_name
    from navbench.sim.backends import PoseRenderer
    from navbench.worldmodel.views import collect_views

    shown = []
    with PoseRenderer(cfg.sim, level, camera_by_name(cfg.camera), CAMERA_HEIGHT) as cam:
        def render(pose):
            frame = cam.render(pose)
            shown.append(cam.shown)
            return frame

        views = collect_views(level, cfg.count, camera_by_name(cfg.camera), cfg.seed, progress=update,
                              renderer=render)
        return dataclasses.replace(views, poses=np.array(shown), intrinsics=cam.intrinsics,
                                   meta={**views.meta, "sim": cfg.sim})
