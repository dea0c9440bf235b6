"""How much memory this process may still use, and a check to run before a large allocation.

Sizes that come from the user (a view count, a camera, a grid shape) can ask for more memory
than the machine has. numpy then either raises ``MemoryError`` deep inside a computation or,
with Linux overcommit, gets the memory and is killed by the kernel while filling it (a
``collect-views --count 100000000`` grew to 23.5 GB before the kernel stopped it). Callers
compute the bytes they are about to need and call :func:`check_memory` first, which refuses with
one :class:`~navbench.errors.ConfigError` line giving the need and what is available.
"""

from __future__ import annotations

import os
from pathlib import Path

from navbench.errors import ConfigError


def _meminfo_available() -> int | None:
    """``MemAvailable`` of ``/proc/meminfo`` in bytes (Linux), else None."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    parts = line.split()
                    return int(parts[1]) * (1024 if parts[2:3] == ["kB"] else 1)
    except (OSError, ValueError, IndexError):
        pass
    return None


def _cgroup_available() -> int | None:
    """What the process's memory cgroup still allows (limit - usage), when it sets a limit.

    A container's cgroup can be far smaller than the machine's ``MemAvailable``; the kernel
    kills the process at the cgroup limit. cgroup v2 (``memory.max``) and v1
    (``memory/memory.limit_in_bytes``) are read; no limit or no cgroup: None.
    """
    for limit_f, usage_f in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                             ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                              "/sys/fs/cgroup/memory/memory.usage_in_bytes")):
        try:
            limit = Path(limit_f).read_text().strip()
            usage = int(Path(usage_f).read_text().strip())
        except (OSError, ValueError):
            continue
        if limit == "max" or not limit.isdigit() or int(limit) >= 1 << 60:  # "no limit"
            return None
        return max(0, int(limit) - usage)
    return None


def available_memory() -> int | None:
    """Bytes of memory this process can still allocate, or None when it cannot be told.

    Linux: ``MemAvailable`` (free memory plus reclaimable caches), capped by the cgroup's
    remaining allowance; elsewhere ``os.sysconf`` free physical pages x page size.
    """
    avail = _meminfo_available()
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            avail = None
    cg = _cgroup_available()
    if cg is not None:
        avail = cg if avail is None else min(avail, cg)
    return avail


def format_bytes(n: float) -> str:
    """``n`` bytes in binary units, e.g. ``15.4 TiB``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024.0
    return f"{n:.1f} PiB"  # pragma: no cover - the loop returns


def check_memory(need: int, what: str) -> None:
    """Raise :class:`ConfigError` when ``need`` bytes exceed the available memory.

    ``what`` names the request in the message (``"collect-views --count 100000000: 100000000
    views of 160x120 (count x H x W x 8 bytes)"``). When the available memory cannot be told,
    nothing is checked.
    """
    avail = available_memory()
    if avail is not None and need > avail:
        raise ConfigError(f"{what} need {format_bytes(need)} of memory, only "
                          f"{format_bytes(avail)} is available")
