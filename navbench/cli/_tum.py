"""The TUM RGB-D reading options ``import-views`` and ``fit-map --views DIR`` share: their typer
declarations (:data:`OPTIONS`) and the checks that turn them into an
:class:`~navbench.pipeline.stages.imported.ImportOptions` (:func:`import_options`)."""

from __future__ import annotations

import math

import typer

from navbench.cli._help import default
from navbench.worldmodel.tum import MAX_HEIGHT_DEV, MAX_TILT_DEG  # light: numpy only

FX = typer.Option(None, "--fx", help=f"Focal length x (px) {default('intrinsics.json')}.")
FY = typer.Option(None, "--fy", help=f"Focal length y (px) {default('--fx')}.")
CX = typer.Option(None, "--cx", help=f"Principal point x (px) {default('width / 2')}.")
CY = typer.Option(None, "--cy", help=f"Principal point y (px) {default('height / 2')}.")
CAMERA_HEIGHT = typer.Option(None, "--camera-height", help="Camera height above the floor (m) "
                             f"{default('intrinsics.json, else the median camera z')}.")
DEPTH_SCALE = typer.Option(None, "--depth-scale", help="Depth PNG units per metre "
                           f"{default('intrinsics.json, else 5000')}.")
MAX_DT = typer.Option(0.02, "--max-dt", help="Timestamp association tolerance (s).")
MAX_TILT = typer.Option(MAX_TILT_DEG, "--max-tilt", help="Refuse a sequence whose cameras tilt "
                        "more than this from planar (deg): navbench fits planar poses and never "
                        "flattens 6-DoF ones.")
MAX_HEIGHT = typer.Option(MAX_HEIGHT_DEV, "--max-height-dev", help="Refuse a sequence whose "
                          "camera z is further than this from the camera height (m).")


def import_options(fx, fy, cx, cy, camera_height, depth_scale, max_dt, max_tilt, max_height_dev):
    """The checked :class:`ImportOptions`; option values no camera or sequence can have are a
    :class:`~navbench.errors.ConfigError` naming the option.

    Focal lengths, camera height and depth scale must be positive and finite, ``--max-dt``,
    ``--max-tilt`` and ``--max-height-dev`` finite and >= 0; ``--fy``/``--cx``/``--cy`` refine
    ``--fx`` and mean nothing without it (the intrinsics then come whole from
    intrinsics.json). The principal point is checked against the image size once that is known.
    """
    from navbench.errors import ConfigError
    from navbench.pipeline.stages.imported import ImportOptions

    from navbench.pipeline.checks import MAX_FLOAT  # finite but absurd (issue 34, P-020)

    for name, v in (("--fx", fx), ("--fy", fy), ("--camera-height", camera_height),
                    ("--depth-scale", depth_scale)):
        if v is not None and not (math.isfinite(v) and 0 < v <= MAX_FLOAT):
            raise ConfigError(f"{name} must be a positive finite number <= {MAX_FLOAT:g}, got {v:g}")
    for name, v in (("--cx", cx), ("--cy", cy)):
        if v is not None and not (math.isfinite(v) and abs(v) <= MAX_FLOAT):
            raise ConfigError(f"{name} must be a finite number (px) of magnitude <= {MAX_FLOAT:g}, got {v:g}")
    for name, v, unit, hi in (("--max-dt", max_dt, "seconds", MAX_FLOAT), ("--max-tilt", max_tilt, "degrees", 180.0),
                              ("--max-height-dev", max_height_dev, "metres", MAX_FLOAT)):
        if not (math.isfinite(v) and 0 <= v <= hi):
            raise ConfigError(f"{name} must be a finite number of {unit} in [0, {hi:g}], got {v:g}")
    if fx is None:
        given = [n for n, v in (("--fy", fy), ("--cx", cx), ("--cy", cy)) if v is not None]
        if given:
            raise ConfigError(f"{'/'.join(given)} given without --fx: give the intrinsics as "
                              f"--fx [--fy --cx --cy], or leave them all to intrinsics.json")
    return ImportOptions(fx, fy, cx, cy, camera_height, depth_scale, max_dt, max_tilt, max_height_dev)
