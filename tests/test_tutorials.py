"""Every page of the site that teaches with Python code runs as written.

The ```python blocks of a page are joined in order (a reader runs them in one session: later
blocks use what earlier ones built) and run in a fresh interpreter, in a temporary folder,
with every warning turned into an error. A page passes when that exits cleanly, prints
nothing to stderr, and prints at least one number and no NaN. Pages that train, need Ray or
play whole rallies are in the slow tier.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"

# page -> (slow tier, modules it needs beyond RallySim's own dependencies)
PAGES: dict[str, tuple[bool, tuple[str, ...]]] = {
    "getting-started.md": (False, ()),
    "envs/simple-return.md": (False, ()),
    # the rally pages play whole rallies in a fresh interpreter: seconds each
    "envs/rally.md": (True, ()),
    "envs/humanlike.md": (True, ()),
    "envs/competitive.md": (True, ()),
    "tutorials/pettingzoo-rally.md": (False, ()),
    "tutorials/sb3-low-level.md": (True, ("stable_baselines3",)),
    "tutorials/hierarchy.md": (True, ("stable_baselines3", "yaml")),
    "tutorials/competitive-play.md": (True, ("stable_baselines3",)),
    "tutorials/rllib.md": (True, ("ray", "torch", "yaml")),
}


def python_code(page: Path) -> str:
    """The page's ```python blocks, joined in order."""
    blocks = re.findall(r"^```python\n(.*?)^```", page.read_text(), re.S | re.M)
    return "\n".join(blocks)


def test_every_page_with_python_code_is_run():
    pages = {str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md")
             if str(p.relative_to(DOCS)).split("/")[0] in ("tutorials", "envs")
             or p.name == "getting-started.md"}
    with_code = {p for p in pages if python_code(DOCS / p)}
    assert with_code == set(PAGES), "add the page to PAGES (and to the site's nav)"


@pytest.mark.parametrize("name", [
    pytest.param(name, marks=[pytest.mark.slow] if slow else [])
    for name, (slow, _) in PAGES.items()])
def test_page_runs_as_written(name, tmp_path):
    for module in PAGES[name][1]:
        pytest.importorskip(module)
    code = python_code(DOCS / name)
    script = tmp_path / "page.py"
    script.write_text(code)
    proc = subprocess.run([sys.executable, "-W", "error", str(script)], capture_output=True,
                          text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, f"{name} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    assert not proc.stderr, f"{name} printed to stderr:\n{proc.stderr[-4000:]}"
    assert re.search(r"\d", proc.stdout), f"{name} printed no numbers:\n{proc.stdout}"
    assert "nan" not in proc.stdout.lower(), proc.stdout
