"""MkDocs hook (``hooks:`` in mkdocs.yml): the generated reference pages, and docs/data/ as data.

``docs/data/`` (the measured data behind the results and the notebook) is copied into the site
file by file: a Markdown file there is data, not a page (:func:`on_files`). On the Python API
page, the Sphinx roles of the docstrings (``:func:``) are dropped (:func:`on_page_content`).

Two pages hold a marker comment that this hook replaces with text generated from navbench's own
structures at build time, so they cannot go stale:

* ``reference/cli.md``: ``<!-- navbench:cli -->`` becomes every command of the typer app
  (:mod:`navbench.cli.main`, sub-apps such as ``db`` and ``cache`` included), each with its
  usage, its help and a table of every argument and option (:func:`render_cli`).
* ``reference/profile-fields.md``: ``<!-- navbench:profile-fields -->`` becomes every field of
  :class:`navbench.pipeline.profiles.Profile` with its place in the TOML file, its default, its
  CLI option, its check (the check's own message, see :func:`describe_check`) and the bundled
  profiles' values, then the tables whose fields come from other dataclasses (``[fit]``,
  ``[navigation.episode]``, ``[conditions]``, ``[navigation.options.<estimator>]``,
  ``goal_localizer``) and the limits (:func:`render_profile_fields`).

The renderers are plain functions (tests/docs imports this file by path and checks that every
command, option and field has an entry: :func:`missing_cli_entries`,
:func:`missing_profile_entries`). The hook puts the checkout that holds ``mkdocs.yml`` first on
``sys.path``, so a build documents that checkout's code, not another installed navbench.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import re
import sys
import textwrap
import typing
from pathlib import Path
from typing import Any, Callable

CLI_MARKER = "<!-- navbench:cli -->"
PROFILE_MARKER = "<!-- navbench:profile-fields -->"
PAGES = {"reference/cli.md": CLI_MARKER, "reference/profile-fields.md": PROFILE_MARKER}


# ------------------------------------------------------------------------------ mkdocs hooks

def on_config(config, **kwargs):
    root = str(Path(config.config_file_path).resolve().parent)
    if root not in sys.path:
        sys.path.insert(0, root)
    return config


DATA_DIR = "data/"


def on_files(files, config, **kwargs):
    """``docs/data/`` is data, not pages: every file there, Markdown included, is copied into the
    site as it is (a link to ``data/x/README.md`` or ``data/x/env.txt`` is checked like a link to
    any file and reaches the file itself)."""
    from mkdocs.structure.files import File

    class DataFile(File):
        def is_documentation_page(self) -> bool:
            return False

    for f in list(files):
        if f.src_uri.startswith(DATA_DIR) and f.is_documentation_page():
            files.remove(f)
            files.append(DataFile(f.src_uri, f.src_dir, f.dest_dir, f.use_directory_urls,
                                  inclusion=f.inclusion))
    return files


def on_page_markdown(markdown: str, page, config, files, **kwargs):
    src = page.file.src_uri
    marker = PAGES.get(src)
    if marker is None:
        return markdown
    if marker not in markdown:
        raise ValueError(f"docs/{src} must hold the marker {marker} (the generated reference goes there)")
    rendered = render_cli() if marker == CLI_MARKER else render_profile_fields()
    return markdown.replace(marker, rendered)


_RST_ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|attr|data|exc|obj|const):(?=<code>)")


def on_page_content(html: str, page, config, files, **kwargs):
    """The Python API page: navbench's docstrings are written for Sphinx-style reading
    (``:func:`x```, a paragraph ending in ``::`` before a literal block); mkdocstrings shows
    them as Markdown, so the role prefixes and the doubled colon are dropped there."""
    if page.file.src_uri != "reference/python-api.md":
        return html
    html = _RST_ROLE.sub("", html)
    return re.sub(r"::(</p>)", r":\1", html)


# ------------------------------------------------------------------------------ helpers

def _plain(text: str | None) -> str:
    """Typer help (rich markup, ``\\b`` blocks) as Markdown: markup removed, ``\\b`` blocks as
    preformatted text, ``|`` escaped for tables by the caller."""
    if not text:
        return ""
    try:
        from rich.text import Text

        text = Text.from_markup(text).plain
    except Exception:  # noqa: BLE001 - text that is not valid markup is shown as written
        pass
    paragraphs = []
    for p in inspect.cleandoc(text).split("\n\n"):
        if p.startswith("\b"):
            body = p.lstrip("\b").strip("\n")
            paragraphs.append("```text\n" + textwrap.dedent(body) + "\n```")
        else:
            paragraphs.append(" ".join(p.split()))
    return "\n\n".join(paragraphs)


def _cell(text: Any) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _code(text: Any) -> str:
    s = str(text)
    return f"``{s}``" if "`" in s else f"`{s}`"


# ------------------------------------------------------------------------------ the CLI

def _app():
    from navbench.cli.main import app

    return app


def _click_command(app=None):
    import typer.main

    return typer.main.get_command(app or _app())


def _walk(command, path: tuple[str, ...] = ("navbench",), parent_ctx=None):
    """``(path, command, ctx)`` for ``command`` and every visible subcommand, depth first in name order."""
    ctx = command.context_class(command, info_name=path[-1], parent=parent_ctx)
    yield path, command, ctx
    subs = getattr(command, "commands", None) or {}
    for name in sorted(subs):
        sub = subs[name]
        if getattr(sub, "hidden", False):
            continue
        yield from _walk(sub, path + (name,), ctx)


def command_anchor(path: tuple[str, ...]) -> str:
    """The heading id of a command: ``navbench fit-map`` -> ``fit-map``, ``navbench db info``
    -> ``db-info``, the root -> ``navbench``."""
    return "-".join(path[1:]) or "navbench"


def _visible_params(command, ctx, with_help: bool):
    params = list(command.get_params(ctx)) if with_help else list(command.params)
    return [p for p in params if not getattr(p, "hidden", False)]


def param_names(param) -> list[str]:
    """How a user writes the parameter: its option strings, or an argument's name."""
    if getattr(param, "param_type_name", None) == "argument" or type(param).__name__.endswith("Argument"):
        return [(param.metavar or param.name).upper()]
    return list(param.opts) + list(getattr(param, "secondary_opts", []) or [])


def _is_argument(param) -> bool:
    return getattr(param, "param_type_name", None) == "argument" or type(param).__name__.endswith("Argument")


def _type_text(param) -> str:
    if getattr(param, "is_flag", False) and not getattr(param, "secondary_opts", None):
        return "flag"
    annotation = None
    td = getattr(param, "type_descriptor", None)
    if td is not None:
        annotation = getattr(td, "annotation", None)
    name = None
    if annotation is not None:
        inner = [a for a in typing.get_args(annotation) if a is not type(None)]
        if typing.get_origin(annotation) is not None and inner:
            annotation = inner[0]
            inner = [a for a in typing.get_args(annotation) if a is not type(None)] or inner
        name = getattr(annotation, "__name__", None) or str(annotation)
        if isinstance(annotation, type) and issubclass(annotation, __import__("enum").Enum):
            name = " \\| ".join(str(m.value) for m in annotation)
    if name is None and getattr(param, "type", None) is not None:
        name = getattr(param.type, "name", str(param.type))
    lo, hi = getattr(param, "min", None), getattr(param, "max", None)
    if lo is None and hi is None and getattr(param, "type", None) is not None:
        lo, hi = getattr(param.type, "min", None), getattr(param.type, "max", None)
    if lo is not None and hi is not None:
        name += f" in [{lo}, {hi}]"
    elif lo is not None:
        name += f" ≥ {lo}"
    elif hi is not None:
        name += f" ≤ {hi}"
    if getattr(param, "multiple", False):
        name += ", repeatable"
    return name or ""


def _default_text(param) -> str:
    if getattr(param, "required", False):
        return "required"
    d = getattr(param, "default", None)
    if d is None or callable(d) or getattr(param, "is_flag", False) and d is False:
        return ""
    if isinstance(d, (list, tuple)):
        return ", ".join(map(str, d)) if d else ""
    if hasattr(d, "value"):  # an Enum
        d = d.value
    return _code(d)


def _summary(help_text: str | None, limit: int = 160) -> str:
    """The first paragraph of a command's help, cut at a word boundary after ``limit`` characters."""
    first = _plain(help_text).split("\n\n")[0]
    if first.startswith("```"):
        return ""
    if len(first) <= limit:
        return first
    cut = first[:limit].rsplit(" ", 1)[0]
    if cut.count("`") % 2:  # never end inside inline code
        cut = cut[:cut.rindex("`")].rstrip()
    return cut + " …"


def render_cli(app=None) -> str:
    """Every command of the app as Markdown: heading (id :func:`command_anchor`), usage, help, and
    a table of its arguments and options."""
    root = _click_command(app)
    out = []
    commands = list(_walk(root))
    out.append("| command | what it does |\n|---|---|")
    for path, cmd, _ctx in commands[1:]:
        if getattr(cmd, "commands", None):
            continue
        out.append(f"| [{' '.join(path[1:])}](#{command_anchor(path)}) | {_cell(_summary(cmd.help))} |")
    out.append("")
    for path, cmd, ctx in commands:
        level = "##" if len(path) <= 2 else "###"
        out.append(f"{level} {' '.join(path)} {{#{command_anchor(path)}}}\n")
        out.append("```text\n" + cmd.get_usage(ctx).strip() + "\n```\n")
        help_text = _plain(cmd.help)
        if help_text:
            out.append(help_text + "\n")
        subs = [n for n, c in sorted((getattr(cmd, "commands", None) or {}).items()) if not getattr(c, "hidden", False)]
        if subs:
            out.append("Commands: " + ", ".join(f"[{n}](#{command_anchor(path + (n,))})" for n in subs) + ".\n")
        params = _visible_params(cmd, ctx, with_help=len(path) == 1)
        if params:
            out.append("| argument or option | type | default | description |\n|---|---|---|---|")
            for p in params:
                names = " / ".join(_code(n) for n in param_names(p))
                out.append(f"| {names} | {_cell(_type_text(p))} | {_cell(_default_text(p))} | "
                           f"{_cell(_plain(getattr(p, 'help', '')))} |")
            out.append("")
    return "\n".join(out)


def cli_entries(app=None) -> dict[str, list[str]]:
    """``{command anchor: [argument and option names]}`` of every visible command of the app."""
    root = _click_command(app)
    return {command_anchor(path): [param_names(p)[0] for p in _visible_params(cmd, ctx, len(path) == 1)]
            for path, cmd, ctx in _walk(root)}


def _sections(markdown: str) -> dict[str, str]:
    """``{heading id: the text up to the next heading}`` of Markdown headings written ``{#id}``."""
    parts = re.split(r"^#{1,6} [^\n]*\{#([A-Za-z0-9_-]+)\}\s*$", markdown, flags=re.M)
    return {parts[i]: parts[i + 1] for i in range(1, len(parts) - 1, 2)}


def missing_cli_entries(markdown: str, app=None) -> list[str]:
    """``"navbench fit-map --steps"``-style names of every command without a section (a heading
    ``{#anchor}``) and every argument or option without a table row in its command's section."""
    sections = _sections(markdown)
    missing = []
    for anchor, names in cli_entries(app).items():
        if anchor not in sections:
            missing.append(f"command {anchor}")
            continue
        rows = [line for line in sections[anchor].splitlines() if line.startswith("| `")]
        for n in names:
            if not any(re.search(rf"`{re.escape(n)}`", row.split("|")[1]) for row in rows):
                missing.append(f"{anchor} {n}")
    return missing


# ------------------------------------------------------------------------------ profile fields

def _field_comments(cls: type) -> dict[str, str]:
    """``{field: comment}`` from a dataclass's source: the comment on the field's line, else the
    comment lines right above it."""
    try:
        lines, _ = inspect.getsourcelines(cls)
    except (OSError, TypeError):
        return {}
    src = textwrap.dedent("".join(lines))
    lines = src.splitlines()
    out = {}
    for node in ast.parse(src).body[0].body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            line = lines[node.lineno - 1]
            comment = ""
            m = re.search(r"#\s*(.*)$", line)
            if m and "#" not in line.split("=", 1)[-1].split("#", 1)[0]:
                comment = m.group(1)
            if not comment:
                above = []
                i = node.lineno - 2
                while i >= 0 and lines[i].strip().startswith("#"):
                    above.insert(0, lines[i].strip().lstrip("#").strip())
                    i -= 1
                comment = " ".join(above)
            out[node.target.id] = comment.replace("noqa: F401", "").strip()
    return out


def _default(f: dataclasses.Field) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
        return f.default_factory()  # type: ignore[misc]
    return dataclasses.MISSING


def _toml(v: Any) -> str:
    """A value as a TOML file writes it."""
    if v is dataclasses.MISSING:
        return "required"
    if v is None:
        return "(unset)"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{}" if not v else "{" + ", ".join(f"{k} = {_toml(x)}" for k, x in v.items()) + "}"
    if dataclasses.is_dataclass(v):
        return "(table)"
    if isinstance(v, float):
        return f"{v:.12g}" if abs(v) < 1e16 else str(v)
    return str(v)


_PROBE = "?"   # not a safe name, not a choice, not a number: every check rejects it


def describe_check(check: Callable[[Any], None]) -> str:
    """What a profile field's check accepts, in the check's own words: its range when it is a
    :class:`navbench.pipeline.checks.Num`, else the messages it raises for values of the wrong
    type and for an unknown name (with the ``got ...`` part left out)."""
    from navbench.pipeline.checks import Num, _Invalid

    owner = getattr(check, "__self__", None)
    if isinstance(owner, Num):
        try:
            check(object())
        except _Invalid as e:
            return re.sub(r", got .*$", "", str(e), flags=re.S)
    texts: list[str] = []
    scalar_name = False   # a check that wraps a single name in a list (the profile's own name)
    for probe in (object(), _PROBE, [_PROBE], {_PROBE: {}}):
        try:
            check(probe)
        except _Invalid as e:
            raw = str(e)
            if re.search(r", got \[<object", raw):
                scalar_name = True
                continue
            m = re.sub(r", got .*$", "", raw, flags=re.S).strip()
        except Exception:  # noqa: BLE001 - a check that cannot take the probe says nothing by it
            continue
        else:
            continue
        q = re.escape(repr(_PROBE))
        m = re.sub(rf"^unknown value {q}; choose one of (\[.*)$", r"one of \1", m, flags=re.S)
        m = re.sub(rf"^unknown ([\w ]+?) {q} \(known: (.*)\)$", r"each a known \1 (\2)", m, flags=re.S)
        m = re.sub(rf"^{q} is not a safe ([\w ]+?) name \((.*)\)$", r"each a safe \1 name (\2)", m, flags=re.S)
        m = re.sub(rf"^\[navigation\.options\. ?\?\]: unknown estimator {q} \(known: (.*)\)$",
                   r"a table per known estimator (\1)", m, flags=re.S)
        m = re.sub(r"^\?: unknown field; known: .*$", "only the fields listed below", m, flags=re.S)
        if scalar_name:
            if m.startswith("expected a list of"):
                continue
            m = re.sub(r"^each a safe", "a safe", m)
        if m not in texts:
            texts.append(m)
    return "; ".join(texts)


def _num_text(rng: Any, tp: Any = float) -> str:
    from navbench.pipeline.checks import Num, _describe_range

    if isinstance(rng, tuple):
        return "one of " + ", ".join(_code(x) for x in rng)
    if isinstance(rng, Num):
        what = "an integer" if rng.kind == "int" else "a number"
        return what + _describe_range(rng.lo, rng.hi, rng.open_lo, rng.open_hi)
    return ""


def _typed_text(tp: Any, rng: Any) -> str:
    """What :func:`navbench.pipeline.checks._check_typed` accepts for annotation ``tp``."""
    import types

    origin = typing.get_origin(tp)
    optional = ""
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if type(None) in typing.get_args(tp):
            optional = " (or unset)"
        if len(args) > 1:
            return " or ".join(_typed_text(a, rng) for a in args) + optional
        tp, origin = args[0], typing.get_origin(args[0])
    if tp is bool:
        return "true or false" + optional
    if tp is str:
        return (_num_text(rng) if isinstance(rng, tuple) else "a string") + optional
    if tp in (int, float):
        from navbench.pipeline.checks import Num

        return _num_text(rng if isinstance(rng, Num) else Num(tp.__name__, lo=0)) + optional
    if origin is tuple:
        from navbench.pipeline.checks import Num

        args = typing.get_args(tp)
        each = _num_text(rng if isinstance(rng, Num) else Num(args[0].__name__, lo=0))
        return f"a list of {len(args)} numbers, each {each.removeprefix('an ').removeprefix('a ')}" + optional
    return f"not settable from a profile ({tp})"


def _dataclass_rows(cls: type, ranges: dict[str, Any], prefix: str = "", skip: tuple[str, ...] = ()) -> list[str]:
    """Table rows ``| key | default | accepts | meaning |`` of a dataclass's fields (nested
    dataclasses flattened with dotted keys), as :func:`navbench.pipeline.checks._check_table`
    checks them."""
    hints = typing.get_type_hints(cls)
    comments = _field_comments(cls)
    rows = []
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        key = f"{prefix}{f.name}"
        tp = hints[f.name]
        if dataclasses.is_dataclass(tp):
            rows += _dataclass_rows(tp, ranges, f"{key}.")
            continue
        rows.append(f"| {_code(key)} | {_cell(_code(_toml(_default(f))))} | {_cell(_typed_text(tp, ranges.get(key)))} "
                    f"| {_cell(comments.get(f.name, ''))} |")
    return rows


def profile_field_rows() -> list[tuple[str, str]]:
    """``(Profile field, table row)`` for every field of the Profile dataclass."""
    from navbench.pipeline.profiles import FIELDS, OPTION_NAMES, Profile

    comments = _field_comments(Profile)
    rows = []
    for f in dataclasses.fields(Profile):
        place, check = FIELDS[f.name]
        place = place or "[navigation.options.<estimator>]"
        default = _default(f)
        option = OPTION_NAMES.get(f.name, "")
        rows.append((f.name, f"| {_cell(_code(place))}<br>({_code(f.name)}) | {_cell(_code(_toml(default)))} | "
                             f"{_cell(_code(option) if option else '')} | {_cell(describe_check(check))} | "
                             f"{_cell(comments.get(f.name, ''))} |"))
    return rows


def render_profile_fields() -> str:
    import navbench.pipeline.checks as checks
    from navbench.localize import LocalizerConfig
    from navbench.nav.episode import EpisodeConfig
    from navbench.pipeline.profiles import Profile, available_profiles, bundled_field_values
    from navbench.sim.conditions import CONDITIONS
    from navbench.track.registry import estimator_options_config, known_estimators
    from navbench.worldmodel.fit import FitConfig

    out = ["## Every field {#fields}\n",
           "Each row is one field of `navbench.pipeline.profiles.Profile`: where a profile file sets it, "
           "its default when the file leaves it out, the command-line option that overrides it, the check "
           "it must pass (in the words of the check's error message) and what it means.\n",
           "| in the TOML file (field) | default | CLI option | accepts | meaning |",
           "|---|---|---|---|---|"]
    out += [row for _, row in profile_field_rows()]
    names = available_profiles()
    out += ["", "## The bundled profiles {#bundled}\n",
            "The value of each field in the profiles bundled in `navbench/profiles/` "
            "(`navbench all --profile NAME`); a field a file leaves out shows its default.\n",
            "| field | " + " | ".join(_code(n) for n in names) + " |",
            "|---|" + "---|" * len(names)]
    for f in dataclasses.fields(Profile):
        if f.name in ("name",):
            continue
        values = bundled_field_values(f.name)
        out.append(f"| {_code(f.name)} | " + " | ".join(_cell(_code(_toml(values.get(n, '')))) for n in names) + " |")

    out += ["", "## [fit] {#fit}\n",
            "Besides `steps` and `seed`, a profile's `[fit]` table may set any field of "
            "`navbench.worldmodel.fit.FitConfig` (`grid_shape = [nx, ny, nz]` at most "
            f"{checks.MAX_GRID_CELLS:,} cells).\n",
            "| key | default | accepts | meaning |", "|---|---|---|---|"]
    out += _dataclass_rows(FitConfig, checks.FIT_RANGES, skip=("steps", "seed"))

    out += ["", "## [navigation.episode] {#episode}\n",
            "Fields of `navbench.nav.episode.EpisodeConfig`; `planner.*` and `controller.*` are its "
            "nested tables (`[navigation.episode.planner]`).\n",
            "| key | default | accepts | meaning |", "|---|---|---|---|"]
    out += _dataclass_rows(EpisodeConfig, checks.EPISODE_RANGES)

    out += ["", "## [conditions] {#conditions}\n",
            "The paper's simulator conditions by name (`navbench.sim.conditions`); each sets a field of "
            "`[navigation.episode]`. `--condition NAME=VALUE` sets one on the command line.\n",
            "| name | values | default | sets | where the paper states it |", "|---|---|---|---|---|"]
    for c in CONDITIONS.values():
        sets = ", ".join(f"{v} → {_code(c.field)} = {_code(_toml(fv))}" for v, fv in zip(c.values, c.field_values))
        out.append(f"| {_code(c.name)} | {', '.join(_code(v) for v in c.values)} | {_code(c.default)} | "
                   f"{_cell(sets)} | {_cell(c.source)} |")

    out += ["", "## [navigation.options.&lt;estimator&gt;] {#options}\n",
            "Keyword options of an estimator (`track-eval -o ESTIMATOR.KEY=VALUE` takes the same). "
            "`seed`, `vmap`, `intrinsics`, `camera_height` and `renderer` are set by the pipeline and "
            "refused here. An estimator without a table takes no options.\n"]
    for est in known_estimators():
        cfg = estimator_options_config(est)
        if cfg is None:
            out += ["", f"### {est} {{#options-{est}}}\n", f"`{est}` takes no options."]
            continue
        out += ["", f"### {est} {{#options-{est}}}\n", "| key | default | accepts | meaning |", "|---|---|---|---|"]
        out += _dataclass_rows(cfg, checks.OPTION_RANGES)
    out.append("")

    out += ["", "## [navigation] goal_localizer {#goal-localizer}\n",
            "With `goal = \"image\"`: fields of `navbench.localize.LocalizerConfig` for the search of "
            "each goal image in the map (numbers must be ≥ 0; `k` is the stage's own and refused).\n",
            "| key | default | accepts | meaning |", "|---|---|---|---|"]
    out += _dataclass_rows(LocalizerConfig, {}, skip=("k",))

    out += ["", "## Limits {#limits}\n",
            "Generous bounds, far above the paper's protocol, so that a typo cannot plan or allocate "
            "without end (`navbench.pipeline.checks`).\n", "| limit | value |", "|---|---|"]
    for name in sorted(n for n in dir(checks) if n.startswith("MAX_")):
        out.append(f"| {_code(name)} | {getattr(checks, name):,} |")
    return "\n".join(out) + "\n"


def missing_profile_entries(markdown: str) -> list[str]:
    """Profile fields without a row in the field table, and FitConfig / EpisodeConfig fields
    (those a profile may set) without a row in their table."""
    import dataclasses as dc

    from navbench.nav.episode import EpisodeConfig
    from navbench.pipeline.profiles import Profile
    from navbench.worldmodel.fit import FitConfig

    sections = _sections(markdown)
    missing = []

    def has_row(section: str, key: str, column: int) -> bool:
        rows = [r for r in sections.get(section, "").splitlines() if r.startswith("|")]
        return any(len(r.split("|")) > column + 1 and r.split("|")[column].strip().strip("`") == key for r in rows)

    field_rows = [r for r in sections.get("fields", "").splitlines() if r.startswith("|")]
    for f in dc.fields(Profile):
        if not any(f"(`{f.name}`)" in r.split("|")[1] for r in field_rows if len(r.split("|")) > 2):
            missing.append(f"Profile.{f.name}")
    for f in dc.fields(FitConfig):
        if f.name not in ("steps", "seed") and not has_row("fit", f.name, 1):
            missing.append(f"FitConfig.{f.name}")
    for f in dc.fields(EpisodeConfig):
        if dc.is_dataclass(f.type) or f.name in ("planner", "controller"):
            continue
        if not has_row("episode", f.name, 1):
            missing.append(f"EpisodeConfig.{f.name}")
    return missing
