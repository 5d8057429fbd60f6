"""Play evaluation rallies: each of N batched rallies is played exactly once.

Three ways to play, matching the paper's Table VII rows:
- hierarchical: a high-level chooser picks each player's goal at the start of its turn, a
  low-level controller swings (``rally_lengths_turns``);
- random high level: the same with goals ~ U[2, 6] m (``random_goals``);
- monolithic: one policy maps each player's 20-value observation to actions every decision
  (``rally_lengths_direct``).
"""

from __future__ import annotations

import numpy as np

from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.core.tasks.turns import TurnTask
from rallysim.players import PlayerSpec, get_player
from rallysim.policies.registry import resolve
from rallysim.policies.types import HighLevel, LowLevel, Policy

PAPER_CAP = RallyConfig.max_hits  # hits: the paper's rally cap (docs/reference.md §7)
MAX_CAP = 100_000
DECISIONS_PER_HIT = 100  # the stall guard's allowance: 10 s of play per hit


def rules_for_cap(cap: int = PAPER_CAP, shuttle: str = "paper") -> RallyConfig:
    """Cooperative rules whose rallies end only by a landing or at ``cap`` hits: the per-rally
    decision limit (a stall guard) grows with the cap, so it never cuts a rally that is going."""
    if not isinstance(cap, int | np.integer) or not 1 <= cap <= MAX_CAP:
        raise ValueError(f"cap must be an integer number of hits in [1, {MAX_CAP}], got {cap!r}")
    guard = max(RallyConfig.max_decisions, DECISIONS_PER_HIT * int(cap))
    return RallyConfig(shuttle=shuttle, max_hits=int(cap), max_decisions=guard)


def _refuse_stalls(truncated: np.ndarray, length: np.ndarray, config: RallyConfig) -> None:
    """Only a landing or the hit cap may end an evaluation rally: a rally the decision limit
    cut below the cap is an error, not a miss."""
    stalled = truncated & (length < config.max_hits)
    if stalled.any():
        raise RuntimeError(f"{int(stalled.sum())} rallies were cut by the decision limit "
                           f"({config.max_decisions}) at {length[stalled].min()} hits, below "
                           f"the cap of {config.max_hits}; raise RallyConfig.max_decisions")


def random_goals(seed: int, player: str | PlayerSpec = "simple") -> HighLevel:
    """The "Random High-level" baseline: uniform random goals at every turn (SIMPLE: depths
    ~ U[2, 6] m; HUMAN-LIKE: each goal axis uniform over its range)."""
    return resolve("random", "high", player, seed)


def rally_lengths_turns(high_level: HighLevel, low_level: LowLevel | str, n_rallies: int,
                        seed: int, config: RallyConfig | None = None,
                        max_turns: int | None = None,
                        player: str | PlayerSpec = "simple") -> np.ndarray:
    """Lengths of ``n_rallies`` rallies of ``player`` (a kind's name or spec; HUMAN-LIKE
    goals are (M, 3)) played turn by turn (cooperative rules)."""
    return play_turns(high_level, low_level, n_rallies, seed, config, max_turns, player)[0]


def play_turns(high_level: HighLevel | np.ndarray, low_level: LowLevel | str, n_rallies: int,
               seed: int, config: RallyConfig | None = None, max_turns: int | None = None,
               player: str | PlayerSpec = "simple") -> tuple[np.ndarray, int, int]:
    """``rally_lengths_turns`` with what the rallies cost: (lengths, low-level decisions
    simulated, turns played). ``high_level`` may also be an array of goals, one per rally
    (``n_rallies`` rows), that each rally's players keep for the whole rally."""
    turns = TurnTask(n_rallies, low_level, config, seed=seed, player=player)
    turns.reset(np.arange(n_rallies))
    fixed = None
    if isinstance(high_level, np.ndarray):
        fixed = high_level.reshape(n_rallies, *turns.goals.shape[2:])
    # a turn ends with a hit or the rally: a rally has at most max_hits + 1 turns
    if max_turns is None:
        max_turns = turns.rally.config.max_hits + 2
    lengths = np.full(n_rallies, -1, np.int64)
    decisions = played = 0
    for _ in range(max_turns):
        playing = np.flatnonzero(lengths < 0)
        if not len(playing):
            return lengths, decisions, played
        goals = np.empty((n_rallies, *turns.goals.shape[2:]))
        goals[:] = turns.rally.default_goal
        if fixed is not None:
            goals[playing] = fixed[playing]
        else:
            goals[playing] = np.asarray(high_level(turns.observe()[playing])).reshape(
                goals[playing].shape)
        out = turns.step(goals, playing)
        decisions += int(out["decisions"][playing].sum())
        played += len(playing)
        _refuse_stalls(out["truncated"][playing], out["rally_length"][playing],
                       turns.rally.config)
        done = playing[(out["terminated"] | out["truncated"])[playing]]
        lengths[done] = out["rally_length"][done]
    raise RuntimeError(f"rallies still going after {max_turns} turns")


def rally_lengths_direct(policy: Policy, n_rallies: int, seed: int,
                         config: RallyConfig | None = None,
                         player: str | PlayerSpec = "simple") -> np.ndarray:
    """Lengths of ``n_rallies`` rallies of ``player`` (a kind's name or spec) where ``policy``
    acts for both players every decision."""
    task = RallyTask(n_rallies, config, seed=seed, spec=get_player(player))
    task.reset(np.arange(n_rallies))
    max_decisions = task.config.max_decisions + 1  # the stall guard ends every rally by then
    lengths = np.full(n_rallies, -1, np.int64)
    for _ in range(max_decisions):
        playing = lengths < 0
        if not playing.any():
            return lengths
        obs = task.observe().reshape(2 * n_rallies, task.obs_size)
        actions = np.clip(policy(obs), -1.0, 1.0).reshape(n_rallies, 2, task.action_size)
        _, term, trunc, info = task.step(actions, active=playing)
        _refuse_stalls(trunc[playing], info["rally_length"][playing], task.config)
        done = playing & (term | trunc)
        lengths[done] = info["rally_length"][done]
    raise RuntimeError(f"rallies still going after {max_decisions} decisions")
