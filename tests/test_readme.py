"""The README's front page stays true: its Python snippets run without a single warning, its
results table shows the numbers of the committed JSON, and the id it documents for the paper's
low-level task plays exactly what the older id plays."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DATA = ROOT / "docs" / "data"


def python_blocks(text: str) -> list[str]:
    """The bodies of the ```python fenced blocks of a Markdown text."""
    return re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)


def run_quietly(code: str, cwd: Path, timeout: float = 300) -> str:
    """Run ``code`` in a fresh interpreter where every warning is an error; its stdout. Fails
    on a non-zero exit or anything printed to stderr."""
    script = cwd / "snippet.py"
    script.write_text(code)
    proc = subprocess.run([sys.executable, "-W", "error", str(script)], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd)
    assert proc.returncode == 0, f"snippet failed:\n{code}\n{proc.stderr[-4000:]}"
    assert not proc.stderr, f"snippet printed to stderr:\n{code}\n{proc.stderr[-4000:]}"
    return proc.stdout


def test_the_readme_snippets_run_without_warnings(tmp_path):
    blocks = python_blocks(README.read_text())
    assert blocks, "the README has a Python snippet"
    for code in blocks:
        out = run_quietly(code, tmp_path)
        assert out.strip(), f"snippet printed nothing:\n{code}"
        assert "nan" not in out.lower(), out


def _row(table_text: str, method: str) -> list[str]:
    line = next(ln for ln in table_text.splitlines() if ln.startswith(f"| {method} |"))
    return [cell.strip() for cell in line.strip("|").split("|")]


@pytest.mark.parametrize("method", ["HRL", "Random High-level", "Monolithic"])
def test_the_readme_results_are_the_committed_json(method):
    cap50 = json.loads((DATA / "reproduce_default.json").read_text())
    cap1000 = json.loads((DATA / "reproduce_rally_shots_seeds10_cap1000.json").read_text())
    assert (cap50["cap"], cap1000["cap"]) == (50, 1000)
    mean = cap50["methods"][method]["mean"]
    paper = cap50["paper"]["table_vii"][method]["mean"]
    long = cap1000["methods"][method]
    expected = [method, f"{paper:.2f}",
                f"{mean['value']:.2f} [{mean['low']:.2f}, {mean['high']:.2f}]",
                f"{long['mean']['value']:.2f}",
                f"{100 * long['later_miss_rate']['value']:.3f} %"]
    assert _row(README.read_text(), method) == expected


def test_simple_return_v1_with_uniform_goals_plays_v0():
    """What the README and the examples say: ``SimpleReturn-v1`` with ``goals="uniform"`` is
    ``SimpleReturn-v0`` step for step (v0 is made here with Gymnasium's notice silenced)."""
    import gymnasium as gym

    import rallysim  # noqa: F401

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        old = gym.make_vec("RallySim/SimpleReturn-v0", num_envs=8)
    new = gym.make_vec("RallySim/SimpleReturn-v1", num_envs=8, goals="uniform")
    rng = np.random.default_rng(0)
    a, _ = old.reset(seed=3)
    b, _ = new.reset(seed=3)
    np.testing.assert_array_equal(a, b)
    for _ in range(60):
        action = rng.uniform(-1, 1, (8, 3)).astype(np.float32)
        a, ra, ta, ua, _ = old.step(action)
        b, rb, tb, ub, _ = new.step(action)
        for x, y in ((a, b), (ra, rb), (ta, tb), (ua, ub)):
            np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("method", ["HRL", "Random High-level", "Monolithic"])
def test_the_site_home_table_is_the_committed_json(method):
    cap50 = json.loads((DATA / "reproduce_default.json").read_text())
    cap1000 = json.loads((DATA / "reproduce_rally_shots_seeds10_cap1000.json").read_text())
    expected = [method, f"{cap50['paper']['table_vii'][method]['mean']:.2f}",
                f"{cap50['methods'][method]['mean']['value']:.2f}",
                f"{cap1000['methods'][method]['mean']['value']:.2f}"]
    assert _row((ROOT / "docs" / "index.md").read_text(), method) == expected


def test_the_performance_table_is_the_committed_json():
    rows = {r["key"]: r for r in json.loads((DATA / "env_throughput.json").read_text())["rows"]}
    text = (ROOT / "docs" / "performance.md").read_text()
    for key in ("ours_256", "ours_64", "single_simple", "single_humanlike", "single_pendulum"):
        assert f"| {rows[key]['decisions_per_s']:,.0f} |" in text, key


def test_the_benchmarks_low_level_table_is_the_committed_json():
    rows = {r["key"]: r for r in json.loads((DATA / "env_throughput.json").read_text())["rows"]}
    runs = json.loads((DATA / "issue37_a2_ratio_runs.json").read_text())["runs"]
    text = (ROOT / "docs" / "benchmarks.md").read_text()
    for key in ("ours_1", "ours_64", "ours_256", "scripted_256", "single_simple",
                "single_humanlike", "pendulum_256", "single_pendulum"):
        r = rows[key]
        assert f"| {r['decisions_per_s']:,.0f} | {r['physics_per_s']:,.0f} |" in text, key
    # the last run is the committed table's
    assert runs[-1]["ours_256_decisions_per_s"] == rows["ours_256"]["decisions_per_s"]
    ratios = ", ".join(f"{r['ratio'] * 100:.0f} %" for r in runs)
    assert f"({ratios} in five runs)" in text


def test_the_benchmarks_rally_table_is_the_committed_json():
    data = json.loads((DATA / "rally_throughput.json").read_text())
    text = (ROOT / "docs" / "benchmarks.md").read_text()
    ref = data["low-level SimpleReturnVectorEnv, random (reference)"]
    for key, rate in data.items():
        if key != "turn steps/s":
            assert f"| {rate:,.0f} | {rate / ref:.2f}" in text, key


def test_the_first_step_figures_are_the_committed_json():
    results = json.loads((DATA / "first_step.json").read_text())["results"]
    text = (ROOT / "docs" / "performance.md").read_text()
    simple, humanlike = results["RallySim/SimpleReturn-v0"], results["RallySim/HumanLikeReturn-v0"]
    for r in (simple, humanlike):
        assert r["warm_loaded_from_cache"]
        assert f"{r['cold']['first_step_s']:.1f} s" in text
        assert f"{r['warm_median_s']:.2f} s" in text
        assert f"{r['warm_without_scipy_median_s']:.2f} s" in text


def test_the_readme_3d_results_are_the_committed_json():
    data = json.loads((DATA / "reproduce_humanlike.json").read_text())
    assert data["player"] == "humanlike" and data["cap"] == 50
    text = " ".join(README.read_text().split())
    for method in ("HRL", "Random High-level", "Monolithic"):
        mean = data["methods"][method]["mean"]
        shown = f"{method} {mean['value']:.2f} [{mean['low']:.2f}, {mean['high']:.2f}]"
        assert shown in text, shown
    worst = min(v["mean"]["value"] for v in data["methods_per_seed"]["HRL"].values())
    assert worst > 48  # "every seed's hierarchy above 48 hits"
    long = json.loads((DATA / "reproduce_humanlike_cap1000.json").read_text())
    assert long["cap"] == 1000 and long["methods"]["HRL"]["median"]["value"] == 1000
    assert "the median HRL rally of those runs is 1,000" in text
