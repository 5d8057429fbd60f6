"""docs/results.md's tables are what the committed reproduction JSON gives."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rallysim.train.reproduce import RETIRED_CHECKS, current_checks
from rallysim.train.results_doc import BLOCK, blocks, main, regenerate, render

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "results.md"
DATA = ROOT / "docs" / "data"


def test_every_generated_block_matches_its_json():
    doc = DOC.read_text()
    names = blocks(doc)
    assert {"reproduce_default", "reproduce_rally_shots_seeds10",
            "reproduce_rally_shots_seeds10_cap1000", "reproduce_rally_shots_seeds10_generic",
            "reproduce_rally_shots_seeds10_generic_cap1000"} <= set(names)
    assert regenerate(doc, DATA) == doc, "run: python -m rallysim.train.results_doc"
    assert main(["--check"]) == 0


def test_a_changed_number_is_caught(tmp_path):
    doc = DOC.read_text()
    study = "reproduce_rally_shots_seeds10"
    data = json.loads((DATA / f"{study}.json").read_text())
    hrl = data["methods"]["HRL"]["mean"]["value"]
    shown = f"{hrl:.2f}"
    block = next(m["body"] for m in BLOCK.finditer(doc) if m["name"] == study)
    assert shown in block and shown in render(data)
    data["methods"]["HRL"]["mean"]["value"] = hrl + 0.01
    (tmp_path / f"{study}.json").write_text(json.dumps(data))
    for name in {m["name"] for m in BLOCK.finditer(doc)} - {study}:
        (tmp_path / f"{name}.json").write_text((DATA / f"{name}.json").read_text())
    assert regenerate(doc, tmp_path) != doc
    copy = tmp_path / "results.md"
    copy.write_text(doc)
    assert main(["--check", "--doc", str(copy), "--data", str(tmp_path)]) == 1


@pytest.mark.parametrize("setting", ["", "_generic"])
def test_the_default_run_is_the_studys_first_three_seeds(setting):
    """The committed default runs trained seeds 0-2 of the 10-seed study of their numeric
    setting bit for bit: the same recipe, the same rallies. Under both numeric settings the
    table passes every check it prints (the retired capped-share check is not printed)."""
    default = json.loads((DATA / f"reproduce_default{setting}.json").read_text())
    study = json.loads((DATA / f"reproduce_rally_shots_seeds10{setting}.json").read_text())
    assert default["budget"] == {**study["budget"], "seeds": 3}
    assert default["numerics"] == study["numerics"]
    for s in ("0", "1", "2"):
        assert default["per_seed"][s] == study["per_seed"][s]
        for method, seeds in default["methods_per_seed"].items():
            assert seeds[s] == study["methods_per_seed"][method][s]
    assert all(current_checks(default).values())
    assert set(default["checks"]) - set(current_checks(default)) <= RETIRED_CHECKS
    assert f"reproduce_default{setting}" in blocks(DOC.read_text())


HUMANLIKE_DOC = ROOT / "docs" / "humanlike.md"


def test_the_3d_table_matches_its_json():
    """docs/humanlike.md's 3-D Table VII: generated from the committed reproduction JSON."""
    doc = HUMANLIKE_DOC.read_text()
    assert "reproduce_humanlike" in blocks(doc)
    assert regenerate(doc, DATA) == doc, (
        "run: python -m rallysim.train.results_doc --doc docs/humanlike.md")
    data = json.loads((DATA / "reproduce_humanlike.json").read_text())
    assert data["player"] == "humanlike" and data["budget"]["seeds"] >= 3
    assert "Command: `rallysim reproduce --player humanlike`;" in render(data)
    # the targets the page reports as met
    assert data["checks"]["every_seed_hrl_mean_at_least_45"]
    assert data["checks"]["hrl_above_monolithic"] and data["checks"]["hrl_above_random"]


def test_the_3d_table_at_cap_1000_matches_its_json():
    """The cap-1,000 evaluation of the same runs: the median target of issue 39, as measured."""
    doc = HUMANLIKE_DOC.read_text()
    assert "reproduce_humanlike_cap1000" in blocks(doc)
    data = json.loads((DATA / "reproduce_humanlike_cap1000.json").read_text())
    cap50 = json.loads((DATA / "reproduce_humanlike.json").read_text())
    assert data["cap"] == 1000 and data["budget"] == cap50["budget"]
    assert "Command: `rallysim reproduce --player humanlike --cap 1000`;" in render(data)
    assert data["checks"]["hrl_median_at_least_200"]
    hrl = data["methods"]["HRL"]["mean"]
    assert f"mean {hrl['value']:.2f} [{hrl['low']:.2f}, {hrl['high']:.2f}]" in doc


def test_the_quick_3d_table_matches_its_json():
    """The HUMAN-LIKE ``quick`` budget's table: the comparison it exists to show, as measured."""
    doc = HUMANLIKE_DOC.read_text()
    assert "reproduce_humanlike_quick" in blocks(doc)
    data = json.loads((DATA / "reproduce_humanlike_quick.json").read_text())
    assert data["budget"]["name"] == "quick" and data["cap"] == 50
    from rallysim.train.reproduce import HUMANLIKE_BUDGETS

    assert data["budget"] == HUMANLIKE_BUDGETS["quick"].settings()  # today's recipe's run
    assert data["checks"]["hrl_above_monolithic"] and data["checks"]["hrl_above_random"]
    hrl = data["methods"]["HRL"]["mean"]
    assert f"HRL {hrl['value']:.2f} [{hrl['low']:.2f}, {hrl['high']:.2f}]" in doc
    assert data["wall_s"]["total"] < 20 * 60


def test_the_train_speed_before_and_after_matches_its_json():
    """docs/benchmarks.md's training before/after (issue 37): the medians of the runs on disk."""
    import statistics

    data = json.loads((DATA / "issue37_train_speed.json").read_text())
    text = (ROOT / "docs" / "benchmarks.md").read_text()
    medians = {}
    for code in ("before", "after"):
        runs = [r for r in data["runs"] if r["code"] == code]
        assert len(runs) == 4
        raw = [r["raw_env_decisions_per_s"] for r in runs if "raw_env_note" not in r]
        medians[code] = {"raw": statistics.median(raw), **{
            s: statistics.median(r[s]["player_decisions_per_s"] for r in runs)
            for s in ("low", "high", "mono")}}
    for key in ("raw", "low", "high", "mono"):
        before, after = medians["before"][key], medians["after"][key]
        assert f"| {before:,.0f} " in text and f"| {after:,.0f} " in text, key
        assert f"| {after / before:.2f}x |" in text, key


def test_the_side_by_side_table_matches_its_json():
    """docs/benchmarks.md's issue 37 before/after: every row of the side-by-side run on disk,
    each run's number and the ratio of the best."""
    data = json.loads((ROOT / "docs" / "data" / "issue37_side_by_side.json").read_text())
    text = (ROOT / "docs" / "benchmarks.md").read_text()
    assert data["before"] == "ff11adb" and data["rounds"] == 2 and not data["quick"]
    for row in data["rows"].values():
        before, after = row["before"], row["after"]
        assert len(before) == len(after) == 2
        cells = (f"| {row['label']} | {' / '.join(f'{v:,.0f}' for v in before)} | "
                 f"{' / '.join(f'{v:,.0f}' for v in after)} | {max(after) / max(before):.2f}x |")
        assert cells in text, row["label"]


def test_the_mujoco_flags_table_matches_its_json():
    """docs/benchmarks.md's MuJoCo disable flags: every cell is the run's on disk, and the
    flags named as changing the bits are those the run found changing them."""
    data = json.loads((DATA / "mujoco_flags.json").read_text())
    text = (ROOT / "docs" / "benchmarks.md").read_text()
    simple, humanlike = data["kinds"]["SIMPLE"], data["kinds"]["HUMAN-LIKE"]
    assert data["n_envs"] == 256 and data["players"] == 2

    def saving(kind: dict, key: str) -> str:
        return f"{kind['saving'][key]:.1%}".replace("%", " % less") if key in kind["saving"] \
            else "—"

    built = (f"| as built (µs) | {simple['us_per_step']['as_built']:.1f} | "
             f"{humanlike['us_per_step']['as_built']:.1f} |")
    counts = sorted({len(simple["kept"]), len(humanlike["kept"])})
    kept = (f"| the {'-'.join(map(str, counts))} flags that keep the bits | "
            f"{saving(simple, 'kept')} | {saving(humanlike, 'kept')} |")
    rows = [built, kept]
    changing = list(dict.fromkeys([*simple["change_bits"], *humanlike["change_bits"]]))
    for name in changing:
        key = f"kept+{name}"
        rows.append(f"| and `{name}` (other bits) | {saving(simple, key)} | "
                    f"{saving(humanlike, key)} |")
    for row in rows:
        assert row in text, row
    assert changing == ["mjDSBL_DAMPER", "mjDSBL_GRAVITY", "mjDSBL_ACTUATION"]
    assert f"takes {simple['saving']['kept+mjDSBL_GRAVITY']:.0%} off the step" \
        .replace("%", " %") in text
    assert data["date"] == "2026-11-29" and data["rounds"] == 7 and data["test_decisions"] == 60
    assert f"best of {data['rounds']} rounds of {data['steps_per_round']} steps" in text
    # gravity off: the arm's angles move in their last bits only, but they move
    gap = simple["change_bits"]["mjDSBL_GRAVITY"]["qpos"]
    assert 0.0 < gap < 1e-12 and f"differ by up to {gap:.1e} rad" in text


def _seed_row(label: str, per_seed: dict[str, float]) -> str:
    cells = [f"{per_seed[str(s)]:.2f}" if str(s) in per_seed else "" for s in range(10)]
    return f"| {label} | " + " | ".join(cells) + " |"


def _interval(e: dict[str, float]) -> str:
    return f"{e['value']:.2f} [{e['low']:.2f}, {e['high']:.2f}]"


def test_the_task_term_probes_match_their_json():
    """The research log's per-seed tables and pooled numbers of the returnability and ready
    probes are those of the JSON the probes' reports wrote."""
    data = ROOT / "docs" / "data"
    text = (ROOT / "docs" / "research-log" / "reproduce.md").read_text()

    def load(name: str) -> dict:
        return json.loads((data / name).read_text())

    ret, m = load("returnable_probe_seeds10.json"), load("task_terms_seeds10.json")
    g, g_ret = load("task_terms_seeds10_generic.json"), load("returnable_probe_seeds6_generic.json")
    for row in (_seed_row("study", ret["compared_with"]["per_seed"]),
                _seed_row("with the term", ret["per_seed"]),
                _seed_row("machine: study", m["compared_with"]["per_seed"]),
                _seed_row("machine: both terms", m["per_seed"]),
                _seed_row("second setting: study", g["compared_with"]["per_seed"]),
                _seed_row("second setting: returnable only", g_ret["per_seed"]),
                _seed_row("second setting: both terms", g["per_seed"])):
        assert row in text, row
    for e in (ret["pooled"], g["pooled"], m["pooled"]):
        assert _interval(e) in text
    for e in (ret["compared_with"]["paired_difference"], g["compared_with"]["paired_difference"]):
        assert "+" + _interval(e) in text
    assert m["worst_seed"] == ["8", 14.745] and g["seeds_at_40_or_more"] == 10


def test_the_high_action_range_runs_match_their_json():
    """The research log's table of high levels with and without the action-range remedies is
    the JSON's, and so are the numbers its text draws from it."""
    data = json.loads((ROOT / "docs" / "data" / "high_action_range.json").read_text())
    text = (ROOT / "docs" / "research-log" / "reproduce.md").read_text()
    keys = ("default", "bound_only", "anneal_only", "bound_and_anneal", "sweep_bound_and_anneal")
    for r in data["runs"]:
        cells = ("—" if r.get(k) is None else f"{r[k]:.2f}" for k in keys)
        assert f"| {r['setting']}, {r['seed']} | " + " | ".join(cells) + " |" in text
    good = [r for r in data["runs"] if r["default"] >= 40]
    changes = [r["bound_and_anneal"] - r["default"] for r in good]
    assert len(good) == 5 and f"{min(changes):.2f} to +{max(changes):.2f}" in text
    # the same commands gave other bits on the machine of the earlier probes
    earlier = {"machine": "task_terms_seeds10.json", "second": "task_terms_seeds10_generic.json"}
    for r in data["runs"]:
        before = json.loads((ROOT / "docs" / "data" / earlier[r["setting"]]).read_text())
        assert before["per_seed"][str(r["seed"])] != r["default"]


def _goals(goals: list[float]) -> str:
    """Goals as the research log writes them: runs of 0.5 m steps as ``a-b``."""
    if not goals:
        return "none"
    runs = [[goals[0], goals[0]]]
    for g in goals[1:]:
        if abs(g - runs[-1][1] - 0.5) < 1e-9:
            runs[-1][1] = g
        else:
            runs.append([g, g])
    return ", ".join(f"{a:.1f}" if a == b else f"{a:.1f}-{b:.1f}" for a, b in runs)


def test_the_rally_shot_probes_match_their_json():
    """The research log's bands and HRL per seed of the low level trained on rally shots too,
    and of the serves-only probe beside it, are the probes' reports'; so are its pooled
    intervals and its counts of goals."""
    data = ROOT / "docs" / "data"
    text = (ROOT / "docs" / "research-log" / "reproduce.md").read_text()
    widths = {}
    for setting, suffix in (("machine", ""), ("second", "_generic")):
        mixed = json.loads((data / f"rally_shots_seeds10{suffix}.json").read_text())
        serves = json.loads((data / f"task_terms_bands{suffix}.json").read_text())
        assert (mixed["incoming"], mixed["bonus"], mixed["ready"]) == ("mixed", 0.5, 0.5)
        assert serves["incoming"] == "serve" and len(mixed["per_seed"]) == 10
        for s, hrl in mixed["per_seed"].items():
            before = (f"{serves['per_seed'][s]:.2f} | {_goals(serves['band_goals_at_40'][s])}"
                      if s in serves["per_seed"] else "— | —")
            row = (f"| {setting}, {s} | {before} | {hrl:.2f} | "
                   f"{_goals(mixed['band_goals_at_40'][s])} |")
            assert row in text, row
            band = mixed["bands"][s]
            assert [2.0 + 0.5 * i for i, v in enumerate(band) if v >= 40] == \
                mixed["band_goals_at_40"][s]
        label = {"machine": "machine", "second": "second setting"}[setting]
        assert _seed_row(f"{label}: both terms, serves only",
                         mixed["compared_with"]["per_seed"]) in text
        assert _seed_row(f"{label}: both terms and rally shots", mixed["per_seed"]) in text
        assert _interval(mixed["pooled"]) in text and mixed["seeds_at_40_or_more"] == 10
        widths[setting] = ([len(g) for g in serves["band_goals_at_40"].values()],
                           [len(g) for g in mixed["band_goals_at_40"].values()])
    assert min(min(w[1]) for w in widths.values()) == 3
    assert max(max(w[0]) for w in widths.values()) == 4
    for serves_only, mixed_in in widths.values():
        assert f"{sum(serves_only) / len(serves_only):.1f}" in text
        assert f"{sum(mixed_in) / len(mixed_in):.1f}" in text


def test_the_superseded_tables_in_the_research_log_match_their_json():
    """The serves-only recipe's studies, moved to the research log, are still their JSON's."""
    log = ROOT / "docs" / "research-log" / "reproduce.md"
    assert {"reproduce_seeds5", "reproduce_seeds5_cap1000", "reproduce_seeds10",
            "reproduce_seeds10_cap1000", "reproduce_seeds10_generic",
            "reproduce_seeds10_generic_cap1000"} <= set(blocks(log.read_text()))
    assert main(["--check", "--doc", str(log)]) == 0


def test_the_10_seed_studies_meet_the_issue_targets():
    """The 10-seed studies with rally shots, at cap 50 and 1000 under both settings, pass
    every check their tables print, and the results page's worst seeds and climbs are
    theirs."""
    text = DOC.read_text()
    names = {"reproduce_rally_shots_seeds10", "reproduce_rally_shots_seeds10_generic"}
    finals: list[float] = []
    for name in names:
        data = json.loads((DATA / f"{name}.json").read_text())
        assert dict(data["budget"]["low_extra"]) == {"returnable": 0.5, "ready": 0.5,
                                                     "incoming": "mixed"}
        worst = data["methods"]["HRL"]["worst_seed"]["mean"]["value"]
        climb = max(data["high_last_climb"].values())
        assert f"{worst:.2f}" in text and f"{climb:.2f}" in text
        assert all(current_checks(data).values())
        finals.extend(c["high"]["final"]["mean_rally"] for c in data["training"].values())
        # the same policies to 1,000 hits: HRL still above both baselines, disjoint
        long = json.loads((DATA / f"{name}_cap1000.json").read_text())
        assert long["cap"] == 1000 and long["budget"] == data["budget"]
        assert long["checks"]["hrl_above_monolithic"] and long["checks"]["hrl_above_random"]
        assert long["training"] == data["training"]  # the same trained runs
        hrl = long["methods"]["HRL"]["mean"]
        assert f"{hrl['value']:.2f} [{hrl['low']:.2f}, {hrl['high']:.2f}]" in text
    # the research log's range of the high levels' last training evaluations
    log = (ROOT / "docs" / "research-log" / "reproduce.md").read_text()
    assert f"are {min(finals):.2f}-{max(finals):.2f} (" in log


def test_the_capped_shares_on_2000_rallies_match_their_json():
    """results.md quotes, per setting, the seeds whose share of 2,000 HRL rallies reaching the
    cap lies below 90 % with its whole interval, and how many lie above it that way."""
    text = DOC.read_text()
    for name in ("capped_share_seeds10", "capped_share_seeds10_generic"):
        seeds = json.loads((DATA / f"{name}.json").read_text())
        assert sorted(seeds, key=int) == [str(s) for s in range(10)]
        assert {v["rallies"] for v in seeds.values()} == {2000}
        for seed, v in seeds.items():
            share = v["capped_share"]
            assert share["value"] == v["capped"] / 2000
            if share["high"] < 0.9:
                cell = (f"seed {seed}: {100 * share['value']:.1f} % [{100 * share['low']:.1f}, "
                        f"{100 * share['high']:.1f}]")
                assert cell in text, cell
        above = sum(v["capped_share"]["low"] > 0.9 for v in seeds.values())
        below = sum(v["capped_share"]["high"] < 0.9 for v in seeds.values())
        assert f"{below} below, {above} above" in text
    seed0 = json.loads((DATA / "capped_share_seeds10_generic.json").read_text())["0"]
    c = seed0["capped_share"]
    assert f"takes {100 * c['value']:.1f} % [{100 * c['low']:.1f}, {100 * c['high']:.1f}]" in text


def test_the_second_cpus_fingerprints_match_what_the_numerics_page_says():
    """docs/numerics.md: on the AVX-512 EPYC, pinned and candidate training equal the committed
    fingerprints for every stage; native only for low and mono."""
    data = ROOT / "docs" / "data"
    first = json.loads((data / "numerics_fingerprint.json").read_text())
    second = json.loads((data / "numerics_fingerprint_avx512.json").read_text())
    assert second["numerics"]["avx512"] and not first["numerics"]["avx512"]
    same = {name: {stage for stage, h in s["fingerprints"].items()
                   if first["settings"][name]["fingerprints"][stage] == h}
            for name, s in second["settings"].items()}
    assert same == {"native": {"low", "mono"}, "pinned": {"low", "high", "mono"},
                    "candidate": {"low", "high", "mono"}}
    assert "all three stages' weights are identical" in (ROOT / "docs" / "numerics.md").read_text()


def test_a_retired_check_is_not_printed_but_its_run_keeps_it():
    """A JSON written before a check was retired keeps the key; the docs' tables and the
    run's report print only the checks today's code applies."""
    from rallysim.train.reproduce import markdown_report
    data = json.loads((DATA / "reproduce_rally_shots_seeds10_generic.json").read_text())
    assert data["checks"]["every_seed_hrl_capped_fraction_at_least_0.9"] is False
    for text in (render(data), markdown_report(data)):
        assert "capped_fraction" not in text
        line = next(x for x in text.splitlines() if x.startswith("Checks: "))
        assert "hrl_above_monolithic" in line and "**no**" not in line
