"""The repository stands on its own: what its tests, package, README and docs cite is in it.

Scanned: tests/, the package fem_pendulum_fmu/ (Python, C and XML sources), README.md and every
Markdown file under docs/ (whatever folders the docs have). A citation fails when it names

- a path that climbs out of its folder with "../" and does not end on a file or folder of the
  repository (notes kept next to a checkout are not in a clone of it);
- a Markdown page (a name ending in .md) that is not in the repository: by its path, relative to
  the citing file's folder or to the repository's root, or for a bare name any file of that name;
- a folder named shared at the start of a path that the repository does not hold;
- a path under a top folder of the repository (docs/, tests/, benchmarks/, examples/, the
  package, .ci/) that is not there; a path in another project's tree ("scikit-fem's tests/...")
  is not one;
- in prose only (comments, docstrings, Markdown text outside code blocks and code spans): an
  absolute path under a home, work or temporary folder of some machine. Code may use such folders
  (a temporary file, /dev/null, /usr/bin) and a code block may show a message with the path a
  user saw.

A Markdown link or image ([text](target), ![alt](target), a reference definition or an HTML
src/href) with a target that is not a URL or an anchor must name a file of the repository,
relative to the page. Every rule is checked on samples first (test_the_rules_find_what_they_target),
so that a scanner that finds nothing cannot pass unnoticed.
"""

from __future__ import annotations

import functools
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "fem_pendulum_fmu"
TOP_FOLDERS = ("docs", "tests", "benchmarks", "examples", PACKAGE, ".ci")
SOURCE_SUFFIXES = {".py", ".c", ".h", ".xml"}

URL = re.compile(r"\b[a-z][a-z0-9+.-]*://\S+")
PATH_CHARS = r"[\w./*-]"
CLIMBING = re.compile(rf"(?<![\w.])(?:\.\./)+{PATH_CHARS}*")
MARKDOWN_NAME = re.compile(rf"(?<![\w/.-]){PATH_CHARS}*?[\w-]+\.md\b")
SHARED = re.compile(rf"(?<![\w./-])shared/{PATH_CHARS}*")
TOP_PATH = re.compile(rf"(?<![\w./-])(?<!'s )(?:{'|'.join(re.escape(t) for t in TOP_FOLDERS)})/{PATH_CHARS}*")
ABSOLUTE = re.compile(r"(?<![\w.~/$:-])/(?:work|home|tmp|root|mnt|scratch|Users)/[\w.-]+")
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
REFERENCE = re.compile(r"^\s*\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+.*)?$", re.MULTILINE)
HTML_TARGET = re.compile(r"\b(?:src|href)\s*=\s*[\"']([^\"']+)[\"']")
CODE_SPAN = re.compile(r"`[^`\n]*`")


def scanned_files() -> list[Path]:
    """README.md, docs/**/*.md, and the sources under tests/ and the package; not this file, whose samples
    are what the rules look for."""
    files = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    for top in ("tests", PACKAGE):
        files += sorted(
            p for p in (ROOT / top).rglob("*") if p.suffix in SOURCE_SUFFIXES and "__pycache__" not in p.parts
        )
    return [p for p in files if p != Path(__file__).resolve()]


def exists(cited: str, folder: Path) -> bool:
    """The cited path, relative to the citing file's folder or to the root, is in the repository (a * is a
    glob; a trailing '.' or '_' ends the name in prose: 'fmi3_*.c', 'docs/notes/speed_vs_error_*.png')."""
    cited = cited.rstrip(".,;:")
    if not cited or cited in (".", "./"):
        return True
    for base in (folder, ROOT):
        if "*" in cited:
            pattern = (base / cited).resolve(strict=False)
            try:
                relative = pattern.relative_to(ROOT)
            except ValueError:
                continue
            if any(True for _ in ROOT.glob(str(relative))):
                return True
            continue
        target = (base / cited).resolve(strict=False)
        if (target == ROOT or ROOT in target.parents) and target.exists():
            return True
    return False


@functools.cache
def markdown_names() -> frozenset[str]:
    """The names of the repository's Markdown files (its virtual environments' and git's left out)."""
    skip = {".git", ".venv", "node_modules"}
    return frozenset(p.name for p in ROOT.rglob("*.md") if not skip & set(p.relative_to(ROOT).parts))


def markdown_name_exists(cited: str, folder: Path) -> bool:
    """A page by its path, or for a bare name any Markdown file of that name."""
    return exists(cited, folder) or ("/" not in cited and cited in markdown_names())


def python_parts(text: str) -> tuple[str, str]:
    """(prose, words) of a Python source: its comments and docstrings (strings that stand as statements);
    those and every other string literal (what can name a file, where the code's own names, such as
    attributes, cannot)."""
    prose, strings, statement_start = [], [], True
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.COMMENT:
            prose.append(tok.string)
        elif tok.type == tokenize.STRING:
            (prose if statement_start else strings).append(tok.string)
        if tok.type not in (tokenize.NL, tokenize.COMMENT):
            statement_start = tok.type in (tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT)
    return "\n".join(prose), "\n".join(prose + strings)


def c_prose(text: str) -> str:
    """The comments of a C source or an XML file."""
    return "\n".join(re.findall(r"/\*.*?\*/|//[^\n]*|<!--.*?-->", text, flags=re.DOTALL))


def markdown_prose(text: str) -> str:
    """Markdown text outside fenced and indented code blocks, code spans taken out."""
    kept, fenced = [], False
    for line in text.splitlines():
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
            continue
        if fenced or line.startswith("    ") or line.startswith("\t"):
            continue
        kept.append(CODE_SPAN.sub("", line))
    return "\n".join(kept)


def problems(relative: str, text: str) -> list[str]:
    """What the file at `relative` (from the root) with this text cites outside the repository."""
    folder = (ROOT / relative).parent
    suffix = Path(relative).suffix
    found = []
    if suffix == ".md":
        prose, words = markdown_prose(text), text
    elif suffix == ".py":
        prose, words = python_parts(text)
    else:
        prose, words = c_prose(text), text
    everything = URL.sub(" ", words)
    prose = URL.sub(" ", prose)
    for match in CLIMBING.finditer(everything):
        if not exists(match.group(), folder):
            found.append(f"a path out of the repository: {match.group()}")
    for match in MARKDOWN_NAME.finditer(everything):
        if not markdown_name_exists(match.group(), folder):
            found.append(f"a page not in the repository: {match.group()}")
    for match in SHARED.finditer(everything):
        if not exists(match.group(), folder):
            found.append(f"a shared folder not in the repository: {match.group()}")
    for match in TOP_PATH.finditer(prose):
        if not exists(match.group(), ROOT):
            found.append(f"a path not in the repository: {match.group()}")
    for match in ABSOLUTE.finditer(prose):
        found.append(f"an absolute path of some machine: {match.group()}")
    if suffix == ".md":
        found += broken_links(prose, folder)
    return found


def broken_links(prose: str, folder: Path) -> list[str]:
    targets = [m.group(1) for pattern in (LINK, REFERENCE, HTML_TARGET) for m in pattern.finditer(prose)]
    found = []
    for target in targets:
        if target.startswith(("#", "mailto:")) or re.match(r"[a-z][a-z0-9+.-]*:", target):
            continue
        path = target.split("#")[0].split("?")[0]
        if path and not exists(path, folder):
            found.append(f"a link to a file not in the repository: {target}")
    return found


def sample(name: str) -> str:
    """Built from parts, so that this file's own text cites nothing."""
    return {
        "climb": "see ." + "./." + "./notes/seed.py for the seed",
        "page": "figures from DES" + "IGN.md section 2",
        "shared": "figures from sha" + "red/baseline/seed.py",
        "top": "as in do" + "cs/rigid.md and benchmarks/no_such_study.py",
        "absolute": "the converged figures (/wo" + "rk/notes/x.txt and /ho" + "me/someone/y)",
        "link": "[the study](study" + ".py) and ![a figure](missing" + ".png)",
    }[name]


@pytest.mark.parametrize(
    "relative, text, expected",
    [
        ("tests/test_x.py", f"x = 1  # {sample('climb')}\n", ["a path out of the repository"]),
        ("tests/test_x.py", f'"""{sample("page")}."""\n', ["a page not in the repository"]),
        ("fem_pendulum_fmu/x.c", f"/* {sample('shared')} */\n", ["a shared folder not in the repository"]),
        ("tests/test_x.py", f'"""{sample("top")}."""\n', ["a page not in", "a path not in", "a path not in"]),
        ("docs/x.md", f"{sample('absolute')}\n", ["an absolute path", "an absolute path"]),
        ("docs/x.md", f"{sample('link')}\n", ["a link to a file", "a link to a file"]),
    ],
)
def test_the_rules_find_what_they_target(relative, text, expected):
    found = problems(relative, text)
    assert len(found) == len(expected), found
    assert all(f.startswith(e) for f, e in zip(found, expected, strict=True)), found


@pytest.mark.parametrize(
    "relative, text",
    [
        # code may use machine folders; a code block may show what a user saw
        ("tests/test_x.py", 'subprocess.run(["/usr/bin/env", "true"], stdout=open("/dev/null", "w"), cwd="/tmp")\n'),
        ("docs/x.md", "A failed start prints:\n\n    [ERROR] this Python (/tmp/venv/bin/python) cannot run it\n"),
        ("docs/x.md", "Run `FEM_PENDULUM_CACHE=/tmp/cache fem-pendulum run`.\n"),
        # pages and files of the repository, relative to the page or the root; another project's file; a URL
        ("docs/x.md", "[the model](guide/model.md), [home](../README.md), README.md, docs/reference/fmi2.md\n"),
        (
            "tests/test_x.py",
            '"""As scikit-fem\'s tests/test_examples.py runs its examples; docs/notes/speed_vs_error_*.png."""\n',
        ),
        ("docs/x.md", "[FMI](https://fmi-standard.org/docs/3.0/#DESIGN.md) and <https://example.org/a/../b>\n"),
    ],
)
def test_the_rules_leave_what_is_no_citation(relative, text):
    assert problems(relative, text) == []


def test_nothing_cites_what_is_not_in_the_repository():
    files = scanned_files()
    assert len(files) > 100 and ROOT / "README.md" in files  # the scan reaches the tests, the package and docs
    found = {}
    for path in files:
        relative = str(path.relative_to(ROOT))
        listed = problems(relative, path.read_text(errors="replace"))
        if listed:
            found[relative] = listed
    assert found == {}
