"""The documentation stays true to the code: its commands exist, its reference is complete, the site builds,
its pages stay short and free of issue numbers, and the README's links resolve.

* Every command shown in ``README.md``, ``deploy/README.md`` and ``docs/**/*.md`` — in a code block or an
  inline code span, starting with ``mavbridge``, ``sim-vehicle``, ``vessel`` or ``mission`` (bare, or from
  ``.venv/bin/`` or ``/opt/mavbridge/venv/bin/``; after ``sudo -u USER``/``env VAR=…`` too) — names
  subcommands that exist and only ``--flags`` its parser has (the subcommand's parser for ``mavbridge``,
  ``vessel`` and ``mission``; the JSON backend's for ``sim-vehicle --json-backend``).
* ``docs/reference/commands.md`` lists every flag of every parser, ``scenario.md`` and ``companion.md``
  every field of their dataclasses, ``metrics.md`` every key of the shared figures of merit; the fix for a
  failure is ``.venv/bin/python docs/gen_reference.py`` (or, for metrics, a line in the page).
* ``mkdocs build --strict`` succeeds (into a temporary folder, never the repository).
* Every hand-written page under ``docs/`` (``docs/reference/`` is generated) is at most 300 lines, and no page
  (nor ``README.md``, ``deploy/README.md``, ``CHANGELOG.md``) speaks of issue numbers in its prose ("issue 11",
  "issues 3", "#32"): each failure names the page and the line.
* Every relative link of ``README.md`` points at a file.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PROGRAMS = ("mavbridge", "sim-vehicle", "vessel", "mission")
PREFIXES = (".venv/bin/", "/opt/mavbridge/venv/bin/")
FENCE = re.compile(r"^\s*(```|~~~)")
INLINE = re.compile(r"(?<!`)(`+)(?!`)(.+?)(?<!`)\1(?!`)", re.DOTALL)
SUBCOMMAND = re.compile(r"^[a-z][a-z0-9_-]*([|/][a-z][a-z0-9_-]*)*$")


def _load_generator():
    spec = importlib.util.spec_from_file_location("gen_reference", DOCS / "gen_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


GEN = _load_generator()


def doc_files() -> list[Path]:
    """The Markdown files whose commands are checked."""
    return [ROOT / "README.md", ROOT / "deploy" / "README.md", *sorted(DOCS.rglob("*.md"))]


# -- finding the commands -----------------------------------------------------------------------------------

def split_markdown(text: str) -> tuple[list[str], list[str]]:
    """(the lines of its fenced code blocks, continuation lines joined; its prose paragraphs)."""
    code, prose, block, fenced = [], [], [], False
    for line in text.splitlines():
        if FENCE.match(line):
            fenced = not fenced
            continue
        if fenced:
            if block and block[-1].endswith("\\"):
                block[-1] = block[-1][:-1] + " " + line.strip()
            else:
                block.append(line)
        else:
            prose.append(line)
        if not fenced and block:
            code += block
            block = []
    code += block
    return code, "\n".join(prose).split("\n\n")


def inline_spans(paragraph: str) -> list[str]:
    """The inline code spans of a paragraph, whitespace (a span may wrap) made single spaces."""
    return [" ".join(m.group(2).split()) for m in INLINE.finditer(paragraph)]


def shell_segments(line: str) -> list[str]:
    """A shell line without its comment, split into the commands of a chain (&&, ||, ;, a pipe, &)."""
    line = re.sub(r"(^|\s)#.*$", "", line)
    return [part for part in re.split(r"&&|\|\||;|\s\|\s|&\s*$|\s&\s", line) if part.strip()]


def strip_launcher(tokens: list[str]) -> list[str]:
    """The tokens from the program on: leading VAR=value, ``env``, ``sudo -u USER`` dropped."""
    while tokens:
        head = tokens[0]
        if re.match(r"^[A-Za-z_][A-Za-z0-9_]*=", head) or head in ("env", "exec", "time"):
            tokens = tokens[1:]
        elif head == "sudo":
            tokens = tokens[3:] if len(tokens) > 2 and tokens[1] == "-u" else tokens[1:]
        else:
            break
    return tokens


def as_command(text: str) -> list[str] | None:
    """The tokens of ``text`` if it is one of our commands (program name without its prefix first)."""
    tokens = strip_launcher(text.split())
    if not tokens:
        return None
    program = tokens[0]
    for prefix in PREFIXES:
        program = program.removeprefix(prefix)
    if program not in PROGRAMS or len(tokens) < 2:
        return None
    return [program, *tokens[1:]]


def commands_in(text: str) -> Iterator[list[str]]:
    """Every command of ours in a Markdown text: code block lines (each chained command) and inline spans."""
    code, paragraphs = split_markdown(text)
    for line in code:
        for segment in shell_segments(line):
            if (command := as_command(segment)) is not None:
                yield command
    for paragraph in paragraphs:
        for span in inline_spans(paragraph):
            if (command := as_command(span)) is not None:
                yield command


# -- checking one command -----------------------------------------------------------------------------------

def options(parser: argparse.ArgumentParser) -> set[str]:
    """Every option string the parser has (``--x`` and ``-x``)."""
    return {o for action in parser._actions for o in action.option_strings}


def flags_of(token: str) -> list[str]:
    """The ``--flags`` a token names: ``--a``, ``[--a``, ``--a=V``, ``--a/--b``; none for anything else."""
    names = []
    for part in token.strip("[](),;.:`'\"").split("/"):
        name = part.split("=")[0].rstrip("]),;.:")
        if re.match(r"^--[A-Za-z]", name):
            names.append(name)
    return names


def command_errors(tokens: list[str]) -> list[str]:
    """What is wrong with one command: subcommands that do not exist, flags its parser does not have."""
    program, rest = tokens[0], tokens[1:]
    parsers = GEN_PARSERS
    top = program
    if program == "sim-vehicle" and any(t == "--json-backend" or t.startswith("--json-backend=") for t in rest):
        top = "sim-vehicle --json-backend"
    current = [(top, parsers[top])]
    errors = []
    for token in rest:
        if token.startswith("-"):
            for flag in flags_of(token):
                errors += [f"{path} has no flag {flag}" for path, parser in current if flag not in options(parser)]
            continue
        subs = [GEN.subcommands(parser) for _, parser in current]
        if not all(subs):  # a value or a positional argument
            continue
        word = token.strip("`,.;:()")
        if not SUBCOMMAND.match(word):  # a placeholder (SCENARIO, …): the rest cannot be placed
            break
        chosen = []
        for (path, _), choices in zip(current, subs, strict=True):
            for name in re.split(r"[|/]", word):
                if name in choices:
                    chosen.append((f"{path} {name}", choices[name]))
                else:
                    errors.append(f"{path} has no subcommand {name!r} (it has {', '.join(choices)})")
        if not chosen:
            break
        current = chosen
    return errors


GEN_PARSERS = GEN.parsers()


def doc_command_errors() -> list[str]:
    """``file: command: what is wrong`` for every documented command that does not match its parser."""
    found = []
    for path in doc_files():
        for tokens in commands_in(path.read_text(encoding="utf-8")):
            for error in command_errors(tokens):
                found.append(f"{path.relative_to(ROOT)}: `{' '.join(tokens)}`: {error}")
    return found


def test_documented_commands_match_the_parsers() -> None:
    """Every command in the docs names subcommands and flags that exist."""
    assert doc_files()[2:], "no docs/*.md found"
    errors = doc_command_errors()
    assert not errors, "commands in the docs that the parsers refuse:\n" + "\n".join(errors)


def test_the_checker_catches_a_made_up_flag_and_subcommand() -> None:
    """The check above is not vacuous: a made-up flag or subcommand, in a block or a span, is reported."""
    text = ("```bash\n.venv/bin/mavbridge run --connect udpin:0.0.0.0:14551 \\\n    --made-up-flag 3  # no\n```\n\n"
            "Run `sim-vehicle --json-backend 9002 --speedup 5` or `vessel sail` or `mission upload --waypoint 1,2`.")
    errors = [e for tokens in commands_in(text) for e in command_errors(tokens)]
    assert errors == ["mavbridge run has no flag --made-up-flag",
                      "sim-vehicle --json-backend has no flag --speedup",
                      "vessel has no subcommand 'sail' (it has maneuver, sea)"], errors


# -- the reference is complete ------------------------------------------------------------------------------

def sections(text: str) -> dict[str, str]:
    """A page's ``## `` sections by title."""
    parts = re.split(r"^## (.+)$", text, flags=re.MULTILINE)
    return {title.strip(): body for title, body in zip(parts[1::2], parts[2::2], strict=True)}


def test_the_command_reference_lists_every_flag() -> None:
    """docs/reference/commands.md has a section per parser listing each of its option strings."""
    page = sections((DOCS / "reference" / "commands.md").read_text(encoding="utf-8"))
    missing = []
    for path, parser in GEN.all_parsers():
        if path not in page:
            missing.append(f"no section '## {path}'")
            continue
        missing += [f"{path} {o}" for o in sorted(options(parser)) if f"`{o}`" not in page[path]]
    assert not missing, "stale docs/reference/commands.md (run docs/gen_reference.py): " + ", ".join(missing)


def _field_names(cls: type) -> set[str]:
    return {f.name for f in dataclasses.fields(cls)}


def test_the_file_references_list_every_field() -> None:
    """scenario.md lists every scenario, world, sea, start and controller field; companion.md every setting."""
    from mavbridge.companion.config import CompanionConfig
    from mavbridge.lab.scenario import Estimation, Reference, Scenario, Waypoint
    from mavbridge.nmpc.config import NmpcConfig
    from vessel.sea.irregular_sea import IrregularSea
    from vessel.sea.state import SeaState, Start
    from vessel.world import SCENARIO_SECTIONS

    scenario = (DOCS / "reference" / "scenario.md").read_text(encoding="utf-8")
    companion = (DOCS / "reference" / "companion.md").read_text(encoding="utf-8")
    classes = (Scenario, SeaState, IrregularSea, Start, Waypoint, NmpcConfig, Reference, Estimation)
    fields = {name for cls in classes for name in _field_names(cls)} | {"vessel"}
    section_names = {"sea", "start", "waypoint", "controller", "reference", "estimation"}  # a "## name" each
    assert set(SCENARIO_SECTIONS) <= fields | section_names, "a scenario section this test does not know"
    wanted = {"scenario.md": (scenario, fields - section_names - {"world"}),
              "companion.md": (companion, _field_names(CompanionConfig))}
    missing = [f"{page}: {name}" for page, (text, names) in wanted.items() for name in sorted(names)
               if f"`{name}`" not in text]
    missing += [f"scenario.md: ## {name}" for name in sorted(section_names) if f"\n## {name}\n" not in scenario]
    assert not missing, "stale reference pages (run docs/gen_reference.py): " + ", ".join(missing)


def test_the_metrics_page_explains_every_shared_key() -> None:
    """metrics.md names every key of the shared figures of merit and of the companion's loop."""
    from mavbridge.companion.summary import LoopEvents, loop_metrics
    from mavbridge.lab.runlog import RunRecorder, run_metrics

    record = RunRecorder(0.1, background_ms=[1.0])
    keys = set(run_metrics(record, None)) | set(loop_metrics(record, LoopEvents()))
    text = (DOCS / "reference" / "metrics.md").read_text(encoding="utf-8")
    missing = sorted(k for k in keys if f"`{k}`" not in text)
    assert not missing, f"docs/reference/metrics.md does not explain {missing}"


# -- short pages, no issue numbers ----------------------------------------------------------------------------

PAGE_LINES_MAX = 300
ISSUE_NUMBER = re.compile(r"\bissues?\s+#?\d+|(?<![\w&/#])#\d+\b", re.IGNORECASE)
LINK_TARGET = re.compile(r"\]\([^)\s]*\)|\{\s*#[^}]*\}")  # a link's target, an attribute list's id


def hand_written_pages() -> list[Path]:
    """The site's pages a person writes: ``docs/**/*.md`` but the generated ``docs/reference/``."""
    return [p for p in sorted(DOCS.rglob("*.md")) if p.relative_to(DOCS).parts[0] != "reference"]


def long_pages(paths: list[Path], root: Path = ROOT) -> list[str]:
    """``page: N lines`` for every page over ``PAGE_LINES_MAX`` lines (the page's path from ``root``)."""
    counts = {p: len(p.read_text(encoding="utf-8").splitlines()) for p in paths}
    return [f"{p.relative_to(root)}: {n} lines (at most {PAGE_LINES_MAX}; split it into two pages)"
            for p, n in counts.items() if n > PAGE_LINES_MAX]


def issue_mentions(text: str) -> list[tuple[int, str]]:
    """(line number, the words) for each issue number in a page's prose: code blocks and link targets skipped."""
    found, fenced = [], False
    for number, line in enumerate(text.splitlines(), start=1):
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            found += [(number, m.group(0)) for m in ISSUE_NUMBER.finditer(LINK_TARGET.sub("", line))]
    return found


def test_no_hand_written_page_is_over_300_lines() -> None:
    """A page a newcomer reads fits in a few minutes: one that needs more is two pages."""
    pages = hand_written_pages()
    assert len(pages) > 10, "no hand-written pages found under docs/"
    too_long = long_pages(pages)
    assert not too_long, "pages over the limit:\n" + "\n".join(too_long)


def test_no_page_speaks_of_issue_numbers() -> None:
    """Pages say what the software does and measured, not which issue asked for it: no "issue 11", no "#32"."""
    paths = [*doc_files(), ROOT / "CHANGELOG.md"]
    found = [f"{path.relative_to(ROOT)}:{number}: {words!r}" for path in paths if path.is_file()
             for number, words in issue_mentions(path.read_text(encoding="utf-8"))]
    assert not found, "issue numbers in the docs (say what, not which issue):\n" + "\n".join(found)


def test_the_page_checks_catch_issue_numbers_and_long_pages(tmp_path: Path) -> None:
    """The two checks above are not vacuous, and leave code, link targets and heading ids alone."""
    text = ("Irregular seas (issue 11) came first.\nAs Issues #3 asked, see #32.\n"
            "```bash\necho issue 5  # a code block is not prose\n```\n"
            "[deploying](deploy.md#5-field-procedure), a heading { #s-12 }, `vessel` step 2 of 3, &#38; an entity.")
    assert issue_mentions(text) == [(1, "issue 11"), (2, "Issues #3"), (2, "#32")]
    page = tmp_path / "long.md"
    page.write_text("line\n" * (PAGE_LINES_MAX + 1), encoding="utf-8")
    assert long_pages([page], root=tmp_path) == [f"long.md: {PAGE_LINES_MAX + 1} lines (at most {PAGE_LINES_MAX}; "
                                                 "split it into two pages)"]
    page.write_text("line\n" * PAGE_LINES_MAX, encoding="utf-8")
    assert long_pages([page], root=tmp_path) == []


# -- the site builds, the README's links resolve ------------------------------------------------------------

def test_mkdocs_builds_strictly(tmp_path: Path) -> None:
    """``mkdocs build --strict`` (mkdocs.yml: Material, the snippets, link and anchor checks) succeeds."""
    for module in ("mkdocs", "material"):
        if importlib.util.find_spec(module) is None:
            pytest.skip(f"{module} is not installed (pip install -e '.[test]' brings mkdocs and mkdocs-material)")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir",
                           str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert (tmp_path / "site" / "index.html").is_file()


def test_readme_relative_links_resolve() -> None:
    """Every relative link and image of README.md points at a file of the repository."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)\s]+)", text) + re.findall(r"<img[^>]*\bsrc=\"([^\"]+)\"", text)
    relative = [t for t in targets if not re.match(r"^([a-z]+:|#)", t)]
    assert relative, "README.md links to nothing in the repository"
    missing = [t for t in relative if not (ROOT / t.split("#")[0]).is_file()]
    assert not missing, f"README.md links to missing files: {missing}"
