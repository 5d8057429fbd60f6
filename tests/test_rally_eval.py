"""Evaluation rallies: each slot plays exactly one rally; baselines order as expected."""

import numpy as np
import pytest

from rallysim.eval.rally_eval import rally_lengths_direct, rally_lengths_turns, random_goals
from rallysim.policies import ScriptedController
from rallysim.policies.registry import goal_conditioned


@pytest.mark.slow
def test_scripted_hierarchy_rallies_long_and_random_motor_control_does_not():
    lengths = rally_lengths_turns(random_goals(0), "scripted", 32, seed=0)
    assert lengths.shape == (32,) and lengths.min() >= 0 and lengths.max() <= 50
    assert lengths.mean() > 25
    rng = np.random.default_rng(0)
    flails = rally_lengths_direct(lambda o: rng.uniform(-1, 1, (len(o), 3)), 32, seed=0)
    assert flails.mean() < 2


def test_goal_conditioned_low_level_reads_the_goal():
    c = ScriptedController()
    seen = {}

    def low(x):
        seen["x"] = x
        return c.act_return(x)

    act = goal_conditioned(low)
    obs = np.zeros((2, 20), np.float32)
    act(obs, np.array([2.0, 6.0]))
    assert seen["x"].shape == (2, 17) and seen["x"][:, 16].tolist() == [-1.0, 1.0]


def test_the_three_methods_are_summarised_from_the_rallies_they_played():
    """``rallysim.eval.compare``: each method's summary is of its own rallies (capped at 5
    hits here), seed by seed, and the same seeds play the same rallies again."""
    from rallysim.eval.compare import METHODS, evaluate_methods, play_methods
    from rallysim.eval.rally_eval import rules_for_cap
    from rallysim.policies.registry import resolve

    out = evaluate_methods(low="scripted", high="pretrained", mono="pretrained", rallies=4,
                           seeds=2, cap=5)
    assert list(out["methods"]) == list(out["lengths"]) == list(METHODS)
    for method in METHODS:
        lengths = np.concatenate(out["lengths"][method])
        summary = out["methods"][method]
        assert [len(g) for g in out["lengths"][method]] == [4, 4]
        assert (summary["n_rallies"], summary["n_seeds"], summary["cap"]) == (8, 2, 5)
        assert lengths.min() >= 0 and lengths.max() <= 5
        assert summary["mean"]["value"] == pytest.approx(lengths.mean())
        assert summary["capped"] == int((lengths == 5).sum())
        assert summary["survival"][0] == 1.0 and len(summary["survival"]) == 6
    # the first seed's rallies, played again from its evaluation seed
    again = play_methods(resolve("pretrained", "high", "simple", 2_000_000),
                         resolve("scripted", "rally_low"), resolve("pretrained", "mono"), 4,
                         2_000_000, rules_for_cap(5, "paper"))
    assert {m: v.tolist() for m, v in again.items()} == {
        m: g[0] for m, g in out["lengths"].items()}
    with pytest.raises(ValueError, match="rallies and seeds must be >= 1"):
        evaluate_methods(rallies=0)
