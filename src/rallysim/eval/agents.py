"""Competitive players: what acts for one side of N batched games, every decision.

An agent sees its side's rally observations and whether its turn has just begun, and returns
that side's actions. Two shapes cover every policy RallySim has:

- ``Hierarchical(high, low)``: a high level picks a goal when the agent's turn begins and holds
  it; the low level swings toward it every decision (the paper's HRL, the scripted controller,
  random goals, a league's learner);
- ``Direct(policy)``: one network maps observations to actions every decision (Monolithic).

``agent(name)`` builds the reference ladder's players and any exported policy by name (see
``AGENT_NAMES``). Agents hold per-game state (the held goals), sized by ``start(n)``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rallysim.jsondoc import MISSING, not_a_file, read_object
from rallysim.players import PLAYERS, SIMPLE, PlayerSpec, get_player
from rallysim.policies.callables import FixedGoal
from rallysim.policies.registry import PRETRAINED, resolve
from rallysim.policies.types import Agent, HighLevel, LowLevel, Policy

AGENT_NAMES = {
    "random": "goals drawn uniformly from the goal range, the shipped low level",
    "scripted": "the scripted controller with the centre goal (SIMPLE: 4 m)",
    "hrl": "the shipped cooperative HRL agent (simple_high over simple_low; HUMAN-LIKE: "
           "humanlike_high over humanlike_low)",
    "mono": "the shipped cooperative Monolithic agent (simple_mono; SIMPLE only)",
    "simple_compete": "the shipped competitive champion (simple_compete_high over simple_low)",
    "fixed:G": "always the goal G (SIMPLE: the landing depth in m, 2 to 6; HUMAN-LIKE: three "
               "values), the shipped low level; fixed:6, always deep, is the SIMPLE reference "
               "ladder's top rung",
}


class Hierarchical:
    """A high level that picks a goal at the start of each turn, over a goal-following low
    level; goals start at the player's default goal."""

    def __init__(self, high: HighLevel, low: LowLevel, name: str = "hierarchical",
                 player: PlayerSpec = SIMPLE) -> None:
        self.high, self.low, self.name, self.player = high, low, name, player
        self.goals = np.empty((0, *player.goal.shape))

    def start(self, n: int) -> None:
        self.goals = np.empty((n, *self.player.goal.shape))
        self.goals[:] = self.player.goal.default

    def act(self, obs: np.ndarray, started: np.ndarray, rows: np.ndarray) -> np.ndarray:
        if started.any():
            chosen = np.asarray(self.high(obs[started]), np.float64)
            self.goals[rows[started]] = self.player.goal.clip(
                chosen.reshape(self.goals[rows[started]].shape))
        return self.low(obs, self.goals[rows])


class Direct:
    """One policy acting on the rally observation every decision (a Monolithic player)."""

    def __init__(self, policy: Policy, name: str = "direct", player: PlayerSpec = SIMPLE) -> None:
        self.policy, self.name, self.player = policy, name, player

    def start(self, n: int) -> None:
        pass

    def act(self, obs: np.ndarray, started: np.ndarray, rows: np.ndarray) -> np.ndarray:
        return self.policy(obs)


def agent(name: str, player: str | PlayerSpec = "simple", seed: int = 0,
          low: LowLevel | str = "pretrained") -> Agent:
    """The agent ``name`` names: one of ``AGENT_NAMES``, or the path prefix of an exported
    policy (``PREFIX.json``): a high level (played over ``low``) or a Monolithic policy, told
    apart by the role its JSON records."""
    p = get_player(player)
    if name == "random":
        return Hierarchical(resolve("random", "high", p, seed), resolve(low, "rally_low", p),
                            name, p)
    if name == "scripted":
        return Hierarchical(FixedGoal(p.goal.default), resolve("scripted", "rally_low", p),
                            name, p)
    if name == "hrl":
        return Hierarchical(resolve("pretrained", "high", p), resolve(low, "rally_low", p),
                            name, p)
    if name == "mono":
        return Direct(resolve("pretrained", "mono", p), name, p)
    if name.startswith("fixed:"):
        return Hierarchical(resolve(name, "high", p), resolve(low, "rally_low", p), name, p)
    prefix = compete_prefix(name) or Path(name)
    if compete_prefix(name) and name != f"{p.name}_compete":
        raise ValueError(f"{name!r} is a {name[:-len('_compete')]} player: play it as one "
                         f"(--player {name[:-len('_compete')]}), not as a {p.name} player")
    there = not_a_file(prefix.with_suffix(".json")) != MISSING  # (of any kind: the loader
    # then says what it is, a directory say)
    if name == f"{p.name}_compete" and not there:
        # a valid name whose policy is missing: "unknown" (listing the name as valid) misled
        raise ValueError(f"{name!r} is not shipped yet in this installation ({prefix}.json is "
                         "missing); train one and pass its path prefix instead")
    if not there:
        valid = ", ".join(map(repr, AGENT_NAMES))
        raise ValueError(f"unknown competitive player {name!r}; valid: {valid}, or the path "
                         "prefix of an exported high-level or Monolithic policy (PREFIX.json)")
    kind = policy_player(prefix)
    if kind is not None and kind != p.name:
        raise ValueError(f"{name!r} is a {kind} player (its policy takes a {kind} rally "
                         f"observation): play it as one (--player {kind}), not as a {p.name} "
                         "player")
    role = _role(prefix)
    if role == "mono":
        return Direct(resolve(str(prefix), "mono", p), name, p)
    return Hierarchical(resolve(str(prefix), "high", p), resolve(low, "rally_low", p), name, p)


def compete_prefix(name: str) -> Path | None:
    """The shipped champion ``KIND_compete`` names (``PRETRAINED/KIND_compete_high``), for any
    player kind; None for other names."""
    kind = name.removesuffix("_compete")
    return PRETRAINED / f"{kind}_compete_high" if kind != name and kind in PLAYERS else None


def policy_player(prefix: Path) -> str | None:
    """The player kind an exported rally policy (a high level or a Monolithic player) plays:
    the one whose rally observation is as long as the policy's input; None where no kind's
    is (not a rally policy: loading it as one says why)."""
    try:
        sizes = read_object(prefix.with_suffix(".json"), "policy")["architecture"]["sizes"]
    except (ValueError, KeyError, TypeError, IndexError):
        return None
    kinds = [k for k, spec in PLAYERS.items() if spec.rally_obs.size == sizes[0]]
    return kinds[0] if len(kinds) == 1 else None


# the training stages whose policies act on the rally every decision (``Direct`` players)
DIRECT_STAGES = ("mono", "compete_mono")


def _role(prefix: Path) -> str:
    """``mono`` for a policy that acts on the rally every decision, else ``high``."""
    doc = read_object(prefix.with_suffix(".json"), "policy")  # (says what a non-file is)
    metadata = doc.get("metadata")
    stage = metadata.get("stage") if isinstance(metadata, dict) else None
    return "mono" if stage in DIRECT_STAGES else "high"
