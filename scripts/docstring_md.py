"""The docstrings' reStructuredText habits as Markdown, for the documentation site.

teamgym's docstrings use a few reStructuredText forms: roles (``:class:`~a.b.C```), literal
blocks introduced by ``::`` and simple tables (columns under ``====`` rules). Markdown reads
double-backtick code as it is but not these, so :func:`rst_to_markdown` rewrites them: a role
becomes code naming its target (the last part with ``~``), ``text::`` becomes ``text:`` (the
indented block after it stays a code block), a simple table becomes a pipe table, and a
section underlined with dashes (``Parameters`` / ``----------``, items ``name:`` over an
indented description) becomes a bold title over a list. :func:`simple_tables` gives a
docstring's tables as rows of cells (the env pages read the observation tables from it).

Used by ``scripts/gen_env_pages.py`` and, as the griffe extension :class:`RstDocstrings`
(mkdocs.yml), by mkdocstrings for the API pages.
"""

from __future__ import annotations

import re
from typing import Any

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|attr|data|exc|obj|const):`(~?)([^`<]*?)\s*(?:<([^`>]+)>)?`")
_RULE = re.compile(r"^\s*=+(?: +=+)+\s*$")
_UNDERLINE = re.compile(r"^\s*-{3,}\s*$")
_ITEM = re.compile(r"^(\S[^:]*):\s*$")

Table = list[list[str]]


def _role(match: re.Match[str]) -> str:
    tilde, text, target = match.groups()
    if target:  # :class:`title <target>`
        return f"`{text}`"
    return f"`{text.rsplit('.', 1)[-1] if tilde else text}`"


def _columns(rule: str) -> list[int]:
    return [m.start() for m in re.finditer(r"=+", rule)]


def _cells(line: str, starts: list[int]) -> list[str]:
    ends = [*starts[1:], None]
    return [line[a:b].strip() for a, b in zip(starts, ends, strict=True)]


def _parse_table(lines: list[str]) -> Table:
    """A simple table (its lines, from the first rule to the last) as header + rows."""
    starts = _columns(lines[0])
    rows: Table = []
    for line in lines[1:]:
        if _RULE.match(line) or not line.strip():
            continue
        cells = _cells(line, starts)
        if rows and not cells[0]:  # continuation of the row above
            rows[-1] = [f"{a} {b}".strip() for a, b in zip(rows[-1], cells, strict=True)]
        else:
            rows.append(cells)
    return rows


def _table_spans(lines: list[str]) -> list[tuple[int, int]]:
    """``(first, last)`` line indices of every simple table: three rules, header between the first two."""
    spans, i = [], 0
    while i < len(lines):
        if _RULE.match(lines[i]) and i + 2 < len(lines) and _RULE.match(lines[i + 2]):
            end = i + 3
            while end < len(lines) and not _RULE.match(lines[end]):
                end += 1
            if end < len(lines):
                spans.append((i, end))
                i = end + 1
                continue
        i += 1
    return spans


def simple_tables(text: str) -> list[Table]:
    """Every simple table of ``text``, each as its header row and body rows (cells stripped)."""
    lines = text.splitlines()
    return [_parse_table(lines[a : b + 1]) for a, b in _table_spans(lines)]


def markdown_table(rows: Table) -> str:
    """Rows (the first is the header) as a Markdown pipe table."""
    lines = ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in rows]
    lines.insert(1, "|" + "---|" * len(rows[0]))
    return "\n".join(lines)


def _underlined_sections(lines: list[str]) -> list[str]:
    """``Title`` over dashes as ``**Title**``; its ``name:`` items over indented text as a list."""
    out: list[str] = []
    i = 0
    while i < len(lines):
        if i + 1 < len(lines) and lines[i].strip() and _UNDERLINE.match(lines[i + 1]):
            out += [f"**{lines[i].strip()}**", ""]
            i += 2
            while i < len(lines) and (item := _ITEM.match(lines[i])):
                body = []
                i += 1
                while i < len(lines) and (lines[i].startswith((" ", "\t")) or not lines[i].strip()):
                    if not lines[i].strip() and not (i + 1 < len(lines) and lines[i + 1].startswith((" ", "\t"))):
                        break
                    body.append(lines[i].strip())
                    i += 1
                names = ", ".join(f"`{n.strip()}`" for n in item.group(1).split(","))
                out.append(f"* {names}: " + " ".join(b for b in body if b))
            if i < len(lines) and not lines[i].strip():
                out.append("")
                i += 1
            continue
        out.append(lines[i])
        i += 1
    return out


def rst_to_markdown(text: str) -> str:
    """``text`` with roles, ``::`` literal-block markers and simple tables in Markdown."""
    lines = text.splitlines()
    out: list[str] = []
    previous = 0
    for a, b in _table_spans(lines):
        out += lines[previous:a]
        out += markdown_table(_parse_table(lines[a : b + 1])).splitlines()
        previous = b + 1
    out += lines[previous:]
    out = _underlined_sections(out)
    converted = []
    for line in out:
        if line.strip() == "::":
            line = ""
        elif line.endswith("::"):
            line = line[:-1]
        converted.append(_ROLE.sub(_role, line))
    return "\n".join(converted)


try:  # the griffe extension exists where griffe does (the docs venv)
    import griffe
except ImportError:  # pragma: no cover - the package's own venvs have no griffe
    griffe = None

if griffe is not None:

    class RstDocstrings(griffe.Extension):
        """Rewrite every docstring with :func:`rst_to_markdown` as griffe loads it."""

        def on_object(self, *, obj: Any, **kwargs: Any) -> None:
            if obj.docstring is not None:
                obj.docstring.value = rst_to_markdown(obj.docstring.value)
