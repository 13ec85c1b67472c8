"""The documentation stays true to the tree: docs/layout.md names every package and module of
`src/wsmap` (and nothing that is gone), says where each new kind of thing goes, and is the one place
that says so (the README points to it); the README's links to the documentation resolve."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

#: The repository (these checks read files only: they need no import of the package).
ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
LAYOUT = (ROOT / "docs" / "layout.md").read_text()
README = (ROOT / "README.md").read_text()

#: A path of the package as docs/layout.md writes it: a code span `wsmap/...`, a package with its
#: trailing slash, a module with `.py` (placeholders such as `<kind>.py` are not names).
_NAMED = re.compile(r"`(wsmap/[\w/]*?(?:\.py|/)?)`")


def _named_paths() -> set[str]:
    return {m.group(1) for m in _NAMED.finditer(LAYOUT)}


def _is_plugin_folder(package: Path) -> bool:
    """A plug-in folder (`wsmap._plugins`): its `__init__` discovers its modules, so a new plug-in
    is one new file that no page has to name."""
    return "discover(" in (package / "__init__.py").read_text()


def _required_paths() -> set[str]:
    """Every package (`wsmap/a/b/`) and module (`wsmap/a/b/c.py`) of the source tree, less the
    plug-ins of plug-in folders (their folder is named; its `registry` and helpers are not plug-ins)."""
    required = set()
    for init in (SRC / "wsmap").rglob("__init__.py"):
        package = init.parent
        required.add(package.relative_to(SRC).as_posix() + "/")
        plugins = _is_plugin_folder(package)
        for module in package.glob("*.py"):
            if module.name == "__init__.py":
                continue
            stem = module.stem
            if plugins and not stem.startswith("_") and stem != "registry":
                continue
            required.add(module.relative_to(SRC).as_posix())
    return required


def test_layout_names_every_package_and_module():
    missing = sorted(_required_paths() - _named_paths())
    assert not missing, f"docs/layout.md does not name {missing}: add a line on what each holds"


def test_layout_names_nothing_that_does_not_exist():
    gone = sorted(p for p in _named_paths() if not (SRC / p.rstrip("/")).exists())
    assert not gone, f"docs/layout.md names {gone}, which are not in src/ (moved or removed?)"


#: The rows of the one "where a new thing goes" table.
WHERE = ["map kind", "closed form", "IK solver", "collision shape", "named arm", "part of the paper", "LM setting"]


@pytest.mark.parametrize("thing", WHERE)
def test_layout_says_where_each_new_thing_goes(thing):
    table = LAYOUT.split("## Where a new thing goes", 1)[1]
    rows = [line for line in table.splitlines() if line.startswith(f"| {thing} |")]
    assert len(rows) == 1, f"docs/layout.md's table has {len(rows)} rows for a new {thing}"
    where = _NAMED.findall(rows[0])
    assert where, f"the row of a new {thing} names no file or folder of the package"
    for path in where:
        assert (SRC / path.rstrip("/")).exists(), path


def test_the_readme_points_to_the_one_table():
    assert "## Where a new thing goes" not in README, "the table lives in docs/layout.md alone"
    assert "(docs/layout.md#where-a-new-thing-goes)" in README


def test_the_readme_links_to_pages_that_exist():
    for page in re.findall(r"\]\((docs/[^)#]+)", README):
        assert (ROOT / page).is_file(), page


#: The documentation (every page and the README) with its text, for the checks of what it names.
PAGES = {"README.md": README, **{f"docs/{p.name}": p.read_text() for p in sorted((ROOT / "docs").glob("*.md"))}}


@pytest.mark.parametrize("page", sorted(PAGES))
def test_the_scripts_a_page_names_exist(page):
    """A command that names a benchmark or a tool names one that is there (they move by area)."""
    named = set(re.findall(r"\b((?:benchmarks|tools)/[\w/]+\.py)\b", PAGES[page]))
    gone = sorted(p for p in named if not (ROOT / p).is_file())
    assert not gone, f"{page} names {gone}, which do not exist"
