"""MkDocs hooks of the documentation site (``hooks:`` in mkdocs.yml): pages made at build time.

- ``<!-- vsw:cli-reference -->`` becomes the reference of every ``vsw`` command, rendered
  from the parser the program itself builds (:func:`vsw.cli.app.build_parser`): its usage,
  description, options with their help and defaults, exit statuses and environment. Made at
  build time rather than committed, so the page cannot fall behind an option.
- ``<!-- vsw:include PATH -->`` becomes the file PATH (relative to the repository root),
  so benchmarks/results.md and CHANGELOG.md are shown, not copied. A Markdown file's
  relative links are re-aimed from its directory to the page's; any other file (the
  tutorial's model file, inside a code fence) is included as it is.
- The docstrings of the API reference are written for reST (``:func:`walk```): the role
  before each name is dropped, and the name stays as code.
- On every page, a relative link to a file of the repository outside docs/ (source code, the
  README) keeps its text and loses its target: the site carries only docs/, and such a link
  would otherwise break the strict build. A link to nothing at all is left for MkDocs to
  report.
"""

from __future__ import annotations

import argparse
import html
import os
import posixpath
import re
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

CLI_MARKER = "<!-- vsw:cli-reference -->"
INCLUDE = re.compile(r"<!-- vsw:include (?P<path>\S+) -->")
# An inline link or image: [text](target) or [text](target "title"); not reference links.
LINK = re.compile(
    r"(?P<bang>!?)\[(?P<text>[^\]]*)\]\((?P<target>[^)\s]+)(?P<title>\s+\"[^\"]*\")?\)"
)
FENCE = re.compile(r"^(```|~~~)")
# A reST role before inline code in a docstring (":func:`walk`"), as it renders in HTML.
ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|exc|obj|const):(?=<code>)")
WIDTH = 88
"""Columns of the usage lines shown (argparse wraps at the terminal's width otherwise)."""


def _escape(text: str) -> str:
    """Plain text as Markdown that shows it as written (HTML and Markdown syntax escaped)."""
    text = html.escape(text, quote=False)
    return re.sub(r"([\\`*_\[\]|#])", r"\\\1", text)


def _formatter(parser: argparse.ArgumentParser) -> argparse.HelpFormatter:
    """The parser's own help formatter at a fixed width (the page is the same on any terminal)."""
    return parser.formatter_class(prog=parser.prog, width=WIDTH)


def _option_row(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """One table row: the option as invoked (with its value's name) and its help, default
    and required mark as ``--help`` shows them."""
    formatter = _formatter(parser)
    invocation = formatter._format_action_invocation(action)
    text = formatter._expand_help(action) if action.help else ""
    return f"| `{invocation}` | {_escape(' '.join(text.split()))} |"


def _paragraphs(text: str | None) -> list[str]:
    """A description or epilog as Markdown paragraphs (argparse's blank-line breaks kept)."""
    if not text:
        return []
    blocks = [" ".join(b.split()) for b in re.split(r"\n\s*\n", text.strip())]
    return [_escape(b) + "\n" for b in blocks if b]


def _parser_section(parser: argparse.ArgumentParser, level: int) -> list[str]:
    """A parser's usage, description, option groups and epilog."""
    usage = _formatter(parser)
    usage.add_usage(parser.usage, parser._actions, parser._mutually_exclusive_groups)
    out = ["```text", usage.format_help().strip(), "```", ""]
    out += _paragraphs(parser.description)
    for group in parser._action_groups:
        # The subcommands have their own table and sections (cli_reference).
        actions = [
            a
            for a in group._group_actions
            if a.help is not argparse.SUPPRESS and not isinstance(a, argparse._SubParsersAction)
        ]
        if not actions:
            continue
        title = group.title or "options"
        out += [f"{'#' * level} {_escape(title[:1].upper() + title[1:])}", ""]
        out += ["| Option | Meaning |", "| --- | --- |"]
        out += [_option_row(parser, a) for a in actions]
        out.append("")
    return out + _paragraphs(parser.epilog)


def cli_reference() -> str:
    """The Markdown of every ``vsw`` command, from the real parser."""
    from vsw.cli.app import build_parser
    from vsw.cli.parser import ENVIRONMENT, EXIT_STATUS

    parser = build_parser()
    # The top-level epilog's exit statuses and environment are tables here, from their data.
    tables = ("exit status:", "environment:")
    parser.epilog = "\n\n".join(
        b for b in re.split(r"\n\s*\n", parser.epilog or "") if not b.startswith(tables)
    )
    (commands,) = (a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    summary = {c.dest: c.help or "" for c in commands._choices_actions}
    out = ["## vsw", ""]
    out += _parser_section(parser, 3)
    out += ["### Commands", "", "| Command | What it does |", "| --- | --- |"]
    out += [f"| [`{n}`](#vsw-{n}) | {_escape(summary[n])} |" for n in commands.choices]
    out += ["", "### Exit status", "", "| Status | Meaning |", "| --- | --- |"]
    out += [f"| {code} | {_escape(text)} |" for code, text in EXIT_STATUS.items()]
    out += ["", "### Environment", "", "| Variable | Meaning |", "| --- | --- |"]
    out += [f"| `{name}` | {_escape(text)} |" for name, text in ENVIRONMENT]
    out.append("")
    for name, sub in commands.choices.items():
        out += [f"## vsw {name} {{#vsw-{name}}}", "", _escape(summary[name]), ""]
        out += _parser_section(sub, 3)
    return "\n".join(out)


def _outside_links(markdown: str, page_dir: Path) -> str:
    """``markdown`` with each relative link to a repository file outside docs/ made plain text.

    Fenced code is left alone (a ``[x](y)`` there is code, not a link)."""

    def replace(match: re.Match[str]) -> str:
        target = match["target"]
        if re.match(r"^[a-z][a-z0-9+.-]*:|^#|^/", target, re.IGNORECASE):
            return match[0]
        path = (page_dir / target.split("#")[0]).resolve()
        if path.is_relative_to(DOCS) or not path.exists() or not path.is_relative_to(ROOT):
            return match[0]
        return match["text"] if not match["bang"] else match[0]

    lines, fenced = [], False
    for line in markdown.split("\n"):
        if FENCE.match(line.lstrip()):
            fenced = not fenced
        lines.append(line if fenced else LINK.sub(replace, line))
    return "\n".join(lines)


def reaim_links(text: str, source_dir: Path, page_dir: Path) -> str:
    """``text``, written in ``source_dir``, with its relative links made relative to
    ``page_dir`` (absolute links, anchors and URLs as they are)."""

    def reaim(match: re.Match[str]) -> str:
        target = match["target"]
        if re.match(r"^[a-z][a-z0-9+.-]*:|^#|^/", target, re.IGNORECASE):
            return match[0]
        file_part, _, anchor = target.partition("#")
        moved = posixpath.normpath(
            os.path.relpath((source_dir / file_part).resolve(), page_dir).replace(os.sep, "/")
        )
        new = moved + (f"#{anchor}" if anchor else "")
        return f"{match['bang']}[{match['text']}]({new}{match['title'] or ''})"

    return LINK.sub(reaim, text)


def _included(path: str, page_dir: Path) -> str:
    """The file ``path`` of the repository, as the page in ``page_dir`` shows it."""
    source = (ROOT / path).resolve()
    if not source.is_file() or not source.is_relative_to(ROOT):
        raise FileNotFoundError(f"vsw:include names {path}, which is not a file of the repository")
    text = source.read_text(encoding="utf-8")
    if source.suffix != ".md":  # code shown in a fence: its text as it is
        return text.rstrip("\n")
    return reaim_links(text, source.parent, page_dir)


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Fill the generated parts of a page and plain the links that leave the site."""
    page_dir = (DOCS / page.file.src_uri).parent
    if CLI_MARKER in markdown:
        markdown = markdown.replace(CLI_MARKER, cli_reference())
    markdown = INCLUDE.sub(lambda m: _included(m["path"], page_dir), markdown)
    return _outside_links(markdown, page_dir)


def on_page_content(html_text: str, page: Any, config: Any, files: Any) -> str:
    """Drop the reST roles that the API reference's docstrings show before their names."""
    return ROLE.sub("", html_text)
