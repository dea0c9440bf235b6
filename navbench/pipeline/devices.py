"""Where a fit whose device is ``"auto"`` runs: the CPU path, unless ``navbench bench`` measured
the device path faster on this machine.

``FitConfig.device = "auto"`` is the CPU path in the world model itself (one meaning on every
machine). The stages resolve it here, before the fit's cache key is made: where the newest bench
run of this host in the results database has both fit-step rows (``fit_step_ms`` on ``cpu`` and
on a CUDA device) and the CUDA step was faster, and torch sees a CUDA device now, ``auto`` becomes
that device, and the key names it (``device`` and the device path's generation,
:func:`navbench.pipeline.stages.maps.fit_key_settings`). Everywhere else nothing changes: no
bench row, no GPU, or a slower GPU step leave ``auto`` the CPU path with the keys it always had.
"""

from __future__ import annotations

import socket

#: The bench metric both paths are compared by (navbench.bench.table: one step of fit_map).
FIT_STEP_METRIC = "fit_step_ms"


def measured_fit_devices(db, host: str | None = None) -> dict | None:
    """The newest bench run of ``host`` (default: this machine) with a fit step on the CPU and
    on CUDA: ``{"run_id", "cpu_ms", "cuda_ms", "cuda_device"}``, or ``None`` when there is none."""
    frame = db.bench_frame()
    if frame.empty:
        return None
    host = host or socket.gethostname()
    rows = frame[(frame["host"] == host) & (frame["metric"] == FIT_STEP_METRIC)]
    for run_id in sorted(rows["run_id"].unique(), reverse=True):
        run = rows[rows["run_id"] == run_id]
        cpu = run[run["device"] == "cpu"]
        cuda = run[run["device"].str.startswith("cuda")]
        if len(cpu) and len(cuda):
            return {"run_id": int(run_id), "cpu_ms": float(cpu["value"].iloc[-1]),
                    "cuda_ms": float(cuda["value"].iloc[-1]),
                    "cuda_device": str(cuda["device"].iloc[-1])}
    return None


def resolve_auto_fit_device(db, host: str | None = None) -> tuple[str, str]:
    """``(device, why)`` for a fit whose device is ``"auto"``: a CUDA device where this host's
    newest bench measured its fit step faster than the CPU path's and torch sees CUDA now, else
    ``"auto"`` (the CPU path, key unchanged). ``why`` is one line saying which and by what."""
    if db is None:
        return "auto", "auto: the CPU path (no results database to read a bench from)"
    m = measured_fit_devices(db, host)
    if m is None:
        return "auto", "auto: the CPU path (no bench of both fit paths on this machine)"
    figures = f"bench run {m['run_id']}: {m['cuda_ms']:.2f} ms a step on {m['cuda_device']}, {m['cpu_ms']:.2f} on the CPU"
    if not m["cuda_ms"] < m["cpu_ms"]:
        return "auto", f"auto: the CPU path ({figures})"
    import torch

    if not torch.cuda.is_available():
        return "auto", f"auto: the CPU path (torch sees no CUDA device now; {figures})"
    return m["cuda_device"], f"auto: {m['cuda_device']} ({figures})"
