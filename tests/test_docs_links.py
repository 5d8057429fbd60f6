"""The code and the docs point at what the clone holds: every ``docs/reference.md §N`` the
package cites is a section there, and every relative link in the docs names a file that exists."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "docs" / "reference.md"


def _sections() -> set[str]:
    """The numbers of docs/reference.md's headings: "## 4. Shuttle" -> "4", "### 4.3 ..." ->
    "4.3"."""
    heads = re.findall(r"^#{2,3} (\d+(?:\.\d+)?)\.? ", REFERENCE.read_text(), re.M)
    return set(heads)


def _package_files() -> list[Path]:
    src = ROOT / "src" / "rallysim"
    return [p for p in src.rglob("*") if p.suffix in (".py", ".xml", ".yaml")]


def test_every_cited_reference_section_exists():
    sections = _sections()
    assert {"1", "4.3", "5", "10"} <= sections and len(sections) >= 13
    cited = {}
    for path in _package_files():
        for number in re.findall(r"docs/reference\.md §(\d+(?:\.\d+)?)", path.read_text()):
            cited.setdefault(number.rstrip("."), []).append(path.name)
    assert len(cited) >= 10  # the package does cite it, widely
    missing = {n: files for n, files in cited.items() if n not in sections}
    assert not missing, f"cited sections not in docs/reference.md: {missing}"


def test_the_package_cites_no_file_the_clone_lacks():
    stale = [p.name for p in _package_files() if re.search(r"\bSPEC(\.md| §)", p.read_text())]
    assert not stale, f"citing SPEC (not in the clone) instead of docs/reference.md: {stale}"


def test_relative_links_in_the_docs_name_existing_files():
    broken = []
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text()):
            if "://" in target or target.startswith("mailto:"):
                continue
            if not (page.parent / target).exists():
                broken.append(f"{page.relative_to(ROOT)} -> {target}")
    assert not broken, broken


def test_every_docs_page_is_in_the_site_nav():
    """mkdocs.yml's nav names every page under docs/ and only pages that exist (the strict
    build would also fail on either, but only where the docs extra is installed)."""
    nav = set(re.findall(r":\s*([\w./-]+\.md)\s*$", (ROOT / "mkdocs.yml").read_text(), re.M))
    pages = {str(p.relative_to(ROOT / "docs")) for p in (ROOT / "docs").rglob("*.md")}
    assert nav == pages, {"not in the nav": sorted(pages - nav), "missing": sorted(nav - pages)}
