"""Help-text builders for options whose defaults are not literal values of the option.

Typer renders help with rich markup, where ``[default: x]`` is a (bad) style tag and vanishes:
:func:`default` escapes it so that it shows. Defaults that come from a profile are cited with
the bundled profiles' real values (:func:`profile_default`), read from ``navbench/profiles/``
when the CLI is imported, so the help cannot go stale when a profile changes. Reading three
small TOML files costs about a millisecond; nothing heavy is imported here.
"""

from __future__ import annotations

from typing import Any

from rich.markup import escape

from navbench.pipeline.profiles import DEFAULT_PROFILE, available_profiles, bundled_field_values

__all__ = ["DB_HELP", "DB_URL", "DEFAULT_PROFILE", "RUN_VERSION_HELP", "SET_HELP", "VERSION_HELP", "bundled_profiles", "default",
           "profile_default", "profile_help", "profile_values"]

#: Help of the ``--set KEY=VALUE`` option of every command that takes a profile.
SIM_HELP = ("The simulator: pymunk (navbench's exact ray-cast world) or vizdoom (the paper's engine: "
            "its pose and images, navbench's dynamics and collisions; needs pip install "
            "'navbench\\[vizdoom]'). Part of every cache key it affects and of the run's benchmark "
            "version (navbench-1+vizdoom)")
SET_HELP = ("Change one profile field, repeatable: KEY=VALUE, KEY the field's dotted place in the "
            "profile's TOML (fit.steps=300, tasks.count=3, navigation.estimators=ours,gt, "
            "levels=house-1,house-2, navigation.episode.max_steps=300); checked as the profile's "
            "own fields, stored with the run and part of every cache key it affects. Named "
            "options (--tasks, --steps...) win over --set.")


def default(text: str) -> str:
    """``[default: TEXT]``, escaped for rich markup so that typer shows it as written."""
    return escape(f"[default: {text}]")


def _show(value: Any) -> str:
    """A value as the help cites it: lists comma-separated with spaces, so that a long list
    wraps instead of being cut short at the help column's edge."""
    if isinstance(value, (list, tuple)):
        return ", ".join(map(str, value))
    return str(value)


def _and(names: list[str]) -> str:
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def _bundled_order(names: list[str]) -> list[str]:
    """The default profile first, then the others in name order."""
    return sorted(names, key=lambda n: (n != DEFAULT_PROFILE, n))


def profile_values(values: dict[str, Any]) -> str:
    """``quick and six: 2000; paper: 10000``: the bundled profiles grouped by equal value."""
    groups: dict[str, list[str]] = {}
    for name in _bundled_order(list(values)):
        groups.setdefault(_show(values[name]), []).append(name)
    return "; ".join(f"{_and(names)}: {shown}" for shown, names in groups.items())


def profile_default(field: str, fit_key: str | None = None, otherwise: str | None = None) -> str:
    """``[default: the profile's (quick and six: 2000; paper: 10000)]`` for the Profile field
    ``field`` (or the ``[fit] fit_key`` entry of its ``fit`` table), with ``, else OTHERWISE``
    when a profile may leave it unset."""
    values = bundled_field_values(field)
    if fit_key is not None:
        values = {name: fit[fit_key] for name, fit in values.items() if fit_key in fit}
    text = "the profile's"
    if values:
        text += f" ({profile_values(values)})"
    if otherwise is not None:
        text += f", else {otherwise}"
    return default(text)


def bundled_profiles() -> str:
    """``quick, paper, six``: the bundled profile names, the default one first."""
    return ", ".join(_bundled_order(available_profiles()))


def profile_help(what: str = "Profile", shows_default: bool = False) -> str:
    """Help of a ``--profile`` option: the bundled names, or a .toml path. Unless the option's
    own default is ``DEFAULT_PROFILE`` (typer shows it then), the default is named here."""
    text = f"{what}: {bundled_profiles()} (bundled in navbench/profiles/) or a .toml path."
    return text if shows_default else f"{text} {default(DEFAULT_PROFILE)}"


#: The results database when neither --db nor $NAVBENCH_DB is given: the value of
#: navbench.results.db.DEFAULT_DB_URL (a test checks), typed here because that module imports
#: SQLAlchemy, which the CLI does not load just to print its help.
DB_URL = "sqlite:///results/navbench.db"
_DB_FILE = DB_URL.removeprefix("sqlite:///")
#: Names the SQLite file rather than the whole URL: a word wider than the help column is cut
#: short with an ellipsis at 80 columns.
DB_HELP = f"Results database URL {default(f'$NAVBENCH_DB, else the SQLite file {_DB_FILE}')}."
#: --benchmark-version of the commands that run a profile (issue 36).
RUN_VERSION_HELP = ("Benchmark version to run under: the profile takes its settings, and what the profile "
                    "file or --set sets wins (as --set benchmark_version=NAME) "
                    + default("the profile's benchmark_version") + ".")
VERSION_HELP = ("Benchmark version to read (results of two versions are never pooled) "
                + default("the newest version in the selection") + ".")

#: ``--overlap/--no-overlap`` of ``all`` and ``run-navigation`` (issue 36, navbench.pipeline.overlap).
OVERLAP_HELP = ("Build the next levels' views and maps in a background process while a level's "
                "episodes run (several levels, a fitted map, --workers other than 1: one process "
                "beside the workers); the results are identical either way.")
