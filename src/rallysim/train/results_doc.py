"""docs/results.md's tables, generated from the JSON that ``rallysim reproduce`` wrote.

Each generated block sits between ``<!-- BEGIN GENERATED: NAME -->`` and
``<!-- END GENERATED: NAME -->`` and is rendered from ``docs/data/NAME.json`` (a reproduction's
``results*.json``, committed). ``python -m rallysim.train.results_doc`` rewrites the blocks;
``--check`` exits 1 when a block differs from what its JSON gives (a test runs the check), so
the numbers in the docs cannot drift from the run they describe.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rallysim.eval.rally_eval import PAPER_CAP
from rallysim.train.reproduce import current_checks, numerics_line, report_tables
from rallysim.train.study_tables import RENDERERS

BLOCK = re.compile(r"(<!-- BEGIN GENERATED: (?P<name>[\w.-]+) -->\n)(?P<body>.*?)"
                   r"(<!-- END GENERATED: (?P=name) -->)", re.S)


def render(results: dict[str, Any]) -> str:
    """The tables of one reproduction: pooled, per seed, where rallies are lost."""
    b, cap = results["budget"], results["cap"]
    checks = current_checks(results)
    lines = [
        f"{b['seeds']} training seeds, {b['rallies']} evaluation rallies per seed and method, "
        f"rallies capped at {cap} hits.",
        "",
        *_where_run(results),
        *report_tables(results),
        "",
        "Checks: " + ", ".join(f"`{k}` **{'yes' if v else 'no'}**" for k, v in checks.items())
        + ".",
        "",
    ]
    return "\n".join(lines)


def _where_run(results: dict[str, Any]) -> list[str]:
    """For a HUMAN-LIKE reproduction: the command and the numerics it ran with. For a SIMPLE
    one (whose pages give the command in their own words): the numerics where the run recorded
    them, and the low level's task options where the budget set any."""
    b, cap = results["budget"], results["cap"]
    if results.get("player") != "humanlike":
        options = ", ".join(f"`{k}={v}`" for k, v in b.get("low_extra", []))
        line = f"Low-level task options: {options} (not the paper's task). " if options else ""
        line += numerics_line(results) if "numerics" in results else ""
        return [line.rstrip(), ""] if line else []
    command = "rallysim reproduce --player humanlike" + (
        f" --budget {b['name']}" if b["name"] != "default" else "") + (
        f" --cap {cap}" if cap != PAPER_CAP else "")
    return [f"Command: `{command}`; {numerics_line(results)}", ""]


def _renderer(kind: str | None) -> Callable[[dict[str, Any]], str]:
    """What renders a JSON of this kind (``study_tables.RENDERERS``: the studies' of
    docs/competitive.md and docs/rl-alone.md; no kind: a reproduction's)."""
    if kind is None:
        return render
    if kind not in RENDERERS:
        raise ValueError(f"no renderer for JSON of kind {kind!r}; known: "
                         f"{', '.join(RENDERERS)} (or none: a reproduction's)")
    return RENDERERS[kind]


def blocks(doc: str) -> list[str]:
    return [m["name"] for m in BLOCK.finditer(doc)]


def regenerate(doc: str, data_dir: Path) -> str:
    """``doc`` with every generated block rendered again from ``data_dir/NAME.json``."""

    def fill(m: re.Match[str]) -> str:
        path = data_dir / f"{m['name']}.json"
        if not path.is_file():
            raise FileNotFoundError(f"generated block {m['name']!r} needs {path}")
        data = json.loads(path.read_text())
        return m.group(1) + _renderer(data.get("kind"))(data) + m.group(4)

    return BLOCK.sub(fill, doc)


def main(argv: list[str] | None = None) -> int:
    root = Path(__file__).resolve().parents[3]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--doc", type=Path, default=root / "docs" / "results.md")
    parser.add_argument("--data", type=Path, default=root / "docs" / "data")
    parser.add_argument("--check", action="store_true",
                        help="exit 1 if a block differs from its JSON; write nothing")
    args = parser.parse_args(argv)
    doc = args.doc.read_text()
    new = regenerate(doc, args.data)
    if args.check:
        if new != doc:
            print(f"{args.doc}: generated blocks differ from {args.data}; run "
                  "python -m rallysim.train.results_doc", file=sys.stderr)
            return 1
        print(f"{args.doc}: {len(blocks(doc))} generated blocks match their JSON")
        return 0
    args.doc.write_text(new)
    print(f"{args.doc}: {len(blocks(doc))} generated blocks written")
    return 0


if __name__ == "__main__":
    sys.exit(main())
