"""The documentation's shape: README.md a short first page, the MkDocs site's nav and pages in step, and
no page citing what the repository does not hold.

`mkdocs build --strict` (.ci/run) checks the site's links and anchors; these checks need no MkDocs.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README_MAX_LINES = 160
TABLE = re.compile(r"<!-- interface-table:start -->.*?<!-- interface-table:end -->", re.DOTALL)
BASH = re.compile(r"^```bash\n(.*?)^```", re.MULTILINE | re.DOTALL)


def pages() -> list[Path]:
    return [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))]


def own_text(page: Path) -> str:
    """The page's text without the interface table, which is generated from modelDescription.template.xml."""
    return TABLE.sub("", page.read_text())


def test_the_readme_is_a_short_first_page():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= README_MAX_LINES
    setup = text[text.index("## Set-up on a fresh machine") :]
    setup = setup[: setup.index("\n## ")]
    first, second = BASH.findall(setup)  # exactly two commands set up a fresh machine
    assert first.startswith("python3 -m venv .venv && .venv/bin/pip install . && ") and second == "bash .ci/run\n"


def test_every_page_is_in_the_nav_and_every_nav_entry_is_a_page():
    nav = re.findall(r"^\s*-\s+(?:[^:\n]+:\s+)?(\S+\.md)\s*$", (ROOT / "mkdocs.yml").read_text(), re.MULTILINE)
    assert len(nav) == len(set(nav))
    assert {DOCS / name for name in nav} == set(DOCS.rglob("*.md"))


def test_no_page_cites_anything_outside_the_repository():
    outside = re.compile(r"\.\./shared|(?<![\w/])DESIGN\.md|/work/|/tmp/|(?<![\w&/])#\d+\b|\b[Ii]ssue \d+")
    for page in pages():
        found = outside.findall(page.read_text())
        assert not found, f"{page.relative_to(ROOT)} cites {found}"


def test_every_file_a_page_names_exists():
    # paths such as docs/guide/model.md, tests/test_fmu.py or fem_pendulum_fmu/physics/stepping.py; a glob
    # (dist/wheel/*.whl) or a placeholder in capitals is not a file
    named = re.compile(r"(?<![\w./-])((?:docs|tests|benchmarks|examples|fem_pendulum_fmu)/[\w./-]*\w)")
    for page in pages():
        for path in named.findall(own_text(page)):
            assert (ROOT / path).exists(), f"{page.relative_to(ROOT)} names {path}, which does not exist"
