"""Figures quoted from the papers that navbench reports beside its own (no imports, no code).

The report and ``navbench bench`` print these next to navbench's measurements; keeping them in a
module of their own lets any layer read them.
"""

from __future__ import annotations

#: The paper's per-step figures (section 5, fig. 4c; Quadro RTX 8000 GPU), in our units.
PAPER_FIGURES: dict[str, float] = {
    "voxel_render_ms": 50.0,  # one image rendered from the voxel map
    "nerf_render_ms": 2720.0,  # one image rendered from a NeRF map (not part of navbench)
    "emission_track_ms": 250.0,  # one emission-based tracking step
    "ours_track_ms": 60.0,  # one prediction-to-observation tracking step
    "control_step_ms": 62.0,  # ours + control, one full time step
    "control_step_hz": 16.1,
}
PAPER_HARDWARE = "NVIDIA Quadro RTX 8000 GPU + 8 Intel Xeon Gold 6252 cores (2.1 GHz)"
