"""MkDocs hooks (mkdocs.yml ``hooks:``): README sections in pages, and links to the repository.

* A page line ``<!-- readme-sections: Quick start | Reproduced: -->`` is replaced by the
  README's ``## `` sections whose titles start with those prefixes, in README order
  (``(intro)`` is the text between the title and the first section), so the site and the
  README share one text.
* Relative links are resolved from the file they were written in (the README for included
  sections): a file under ``docs/`` is linked from the page; a folder, or a file elsewhere in the
  repository (source, tests, DEVELOPERS.md), is not on the site, so the link becomes its text
  (with the path in code when the text does not name it). A link to nothing stays, and
  ``mkdocs build --strict`` fails on it.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
_INCLUDE = re.compile(r"^<!-- readme-sections: (.+?) -->$", re.MULTILINE)
_LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s]+)\)")
_EXTERNAL = re.compile(r"^(?:[a-z][a-z0-9+.-]*:|#|/)", re.IGNORECASE)


def readme_sections(prefixes: list[str], readme: Path = README) -> str:
    """The README's ``## `` sections whose titles start with one of ``prefixes`` (``(intro)``: before the first)."""
    text = readme.read_text(encoding="utf-8")
    chunks = re.split(r"^(?=## )", text, flags=re.MULTILINE)
    intro = re.sub(r"\A# .*\n", "", chunks[0]).strip("\n")
    picked = [intro] if "(intro)" in prefixes else []
    titled = [p for p in prefixes if p != "(intro)"]
    unknown = [p for p in titled if not any(c[3:].startswith(p) for c in chunks[1:])]
    if unknown:
        raise ValueError(f"{readme.name} has no section starting with {unknown}")
    picked += [c.strip("\n") for c in chunks[1:] if c[3:].startswith(tuple(titled))]
    return "\n\n".join(picked)


def _rewrite(match: re.Match[str], source_dir: Path, page_dir: Path, docs_dir: Path) -> str:
    bang, text, target = match.groups()
    if _EXTERNAL.match(target):
        return match.group(0)
    path_part, hash_, anchor = target.partition("#")
    path = (source_dir / path_part).resolve()
    if not path.exists():
        return match.group(0)  # mkdocs reports it
    if path.is_file() and path.is_relative_to(docs_dir):
        return f"{bang}[{text}]({Path(os.path.relpath(path, page_dir)).as_posix()}{hash_}{anchor})"
    shown = path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else str(path)
    return text if path.name in text else f"{text} (`{shown}`)"


def rewrite_links(markdown: str, source_dir: Path, page_dir: Path, docs_dir: Path) -> str:
    """``markdown``'s relative links (outside fenced code) resolved from ``source_dir`` for a page in ``page_dir``."""
    out, fenced = [], False
    for line in markdown.split("\n"):
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced:
            line = _LINK.sub(lambda m: _rewrite(m, source_dir, page_dir, docs_dir), line)
        out.append(line)
    return "\n".join(out)


def on_page_markdown(markdown: str, *, page: Any, config: Any, **kwargs: Any) -> str:
    docs_dir = Path(config["docs_dir"]).resolve()
    page_dir = (docs_dir / page.file.src_path).parent

    parts = _INCLUDE.split(markdown)  # odd items: the prefixes of an include line
    for i, part in enumerate(parts):
        if i % 2:
            sections = readme_sections([p.strip() for p in part.split("|")])
            parts[i] = rewrite_links(sections, README.parent, page_dir, docs_dir)
        else:
            parts[i] = rewrite_links(part, page_dir, page_dir, docs_dir)
    return "".join(parts)
