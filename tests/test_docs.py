"""The repository stands on its own: every path its documentation and code cite exists
inside it, and nothing points outside it."""

from __future__ import annotations

import re
from pathlib import Path

from tests.helpers import REPO

#: The files a reader follows references from.
TEXTS = sorted([REPO / "README.md", *(REPO / "docs").glob("*.md")])
SOURCES = sorted(p for d in ("trimd", "bench", "tests", "examples") for p in (REPO / d).rglob("*")
                 if p.suffix in {".py", ".yaml", ".md"} and "__snapshots__" not in p.parts)
#: A repository path inside backticks or a Markdown link: starts at a top-level directory.
CITED_PATH = re.compile(r"[`(]((?:docs|trimd|tests|bench|examples|\.ci)/[\w./-]*\w)[`)#]")
SECTION_REF = re.compile(r"docs/method\.md §(\d)")
#: A path to the reference material that lived beside the repository (a parent-relative
#: "shared" directory, or its docs/ and data/).
BESIDE = re.compile(r"\.\./shar[e]d|shar[e]d/(docs|data)")


def _rel(p: Path) -> str:
    return str(p.relative_to(REPO))


def test_every_path_the_docs_cite_exists() -> None:
    cited = {(c, _rel(t)) for t in TEXTS for c in CITED_PATH.findall(t.read_text(encoding="utf-8"))}
    assert len(cited) > 30, "README and docs cite repository paths: is the pattern still right?"
    missing = sorted((t, c) for c, t in cited if not (REPO / c).exists())
    assert not missing, f"cited paths that do not exist: {missing}"


def test_nothing_points_outside_the_repository() -> None:
    outside = [f"{_rel(p)}:{i}" for p in [*TEXTS, *SOURCES] if p != Path(__file__)
               for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
               if BESIDE.search(line)]
    assert not outside, f"references to a directory beside the repository: {outside}"


def test_method_sections_cited_in_the_code_exist() -> None:
    headings = set(re.findall(r"^## §(\d) ", (REPO / "docs/method.md").read_text(encoding="utf-8"),
                              flags=re.M))
    cited = {(m, _rel(p)) for p in [*TEXTS, *SOURCES]
             for m in SECTION_REF.findall(p.read_text(encoding="utf-8"))}
    assert len(cited) > 10, "docstrings cite docs/method.md by section"
    assert not [c for c in cited if c[0] not in headings], headings
