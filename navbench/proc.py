"""Process identity: whether a recorded process still runs, and an id its pid's next owner lacks.

Used by the results database (a run row's owner), the artifact cache (who holds an entry) and
the executor (workers watching their parent). Standard library only; no navbench imports, so any
layer may use it.
"""

from __future__ import annotations

import os


def process_start_token(pid: int) -> str | None:
    """An id of the process ``pid`` that a later process with the same pid will not have.

    On Linux: ``BOOT/PIDNS:START``, the boot id, this process's PID namespace (a pid is only
    meaningful within one) and the process's start time (clock ticks since boot, field 22 of
    ``/proc/PID/stat``); elsewhere (or when it cannot be read) ``None``.
    """
    try:
        with open(f"/proc/{int(pid)}/stat", "rb") as f:
            stat = f.read().decode(errors="replace")
        with open("/proc/sys/kernel/random/boot_id", encoding="ascii") as f:
            boot = f.read().strip()
        ns = os.readlink("/proc/self/ns/pid")
        return f"{boot}/{ns}:{stat.rsplit(')', 1)[1].split()[19]}"
    except (OSError, IndexError, ValueError):
        return None


def pid_alive(pid: int, start_token: str | None = None) -> bool:
    """Whether process ``pid`` still runs (a zombie does not) and, when ``start_token`` (from
    :func:`process_start_token`) is given and the current one can be read, is the same process
    rather than a later one that reuses its pid."""
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # it exists, owned by another user
    except (OSError, OverflowError, ValueError):
        return False
    try:
        with open(f"/proc/{int(pid)}/stat", "rb") as f:
            if f.read().decode(errors="replace").rsplit(")", 1)[1].split()[0] == "Z":
                return False
    except (OSError, IndexError):
        pass
    if start_token is not None:
        now = process_start_token(pid)
        if now is not None and now != start_token:
            return False
    return True
