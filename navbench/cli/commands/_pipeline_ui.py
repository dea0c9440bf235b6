"""Shared glue of the pipeline commands: rich progress bars, the stage context, profile options.

Not a command module (the leading underscore keeps it out of discovery). Imports only light
modules at import time.
"""

from __future__ import annotations

import sys
import time

from navbench.pipeline.console import PipelineUI, RateColumn  # noqa: F401 -- the commands' names


def run_with_ui(body, json_mode: bool = False):
    """``body(ui)`` with rich progress bars drawn around it; Ctrl-C prints how to resume and
    exits 130 (the run is recorded as interrupted by :func:`navbench.pipeline.run.recorded_run`)."""
    ui = PipelineUI(json_mode=json_mode)
    try:
        with ui:
            return body(ui)
    except BaseException as e:
        from navbench.errors import caused_by_interrupt

        # Ctrl-C, also when it arrived inside a numba kernel (a SystemError chained to the
        # KeyboardInterrupt: a standalone fit-map printed that chain)
        if not caused_by_interrupt(e) or isinstance(e, SystemExit):
            raise
        # exit 130 ourselves: the CLI shell would turn it into exit status 0
        ui.console.print("interrupted: rerun the same command to finish; stored episodes are kept",
                         style="yellow")
        raise SystemExit(130) from None


def load_profile_with(profile: str | None, sets: list[str] | None = None, **overrides):
    """Load a profile, apply the ``--set KEY=VALUE`` items, then the CLI's non-None overrides;
    its simulator must be installed (:func:`navbench.sim.backends.require_sim`)."""
    from navbench.pipeline.overrides import apply_sets
    from navbench.pipeline.profiles import load_profile, override
    from navbench.sim.backends import require_sim

    prof = override(apply_sets(load_profile(profile), sets), **overrides)
    require_sim(prof.sim, "--sim" if overrides.get("sim") is not None else f"profile {prof.name}: sim")
    return prof


def warn_ignored_textures(prof) -> None:
    """Say in one line (stderr) when ``prof``'s texture modes do nothing on its simulator
    (:func:`navbench.pipeline.profiles.ignored_textures_note`); ``run_profile`` says it for its
    commands."""
    from navbench.pipeline.profiles import ignored_textures_note

    note = ignored_textures_note(prof)
    if note:
        from navbench.cli._common import err_console

        err_console.print(f"warning: {note}", style="yellow", markup=False, highlight=False)


def command_line() -> str:
    """The command line as typed (for the runs table)."""
    return " ".join(["navbench", *sys.argv[1:]])[:256]


def elapsed_since(t0: float) -> str:
    return f"{time.perf_counter() - t0:.1f} s"
