"""The sections of a training configuration: ``ppo``, ``warm_start``, ``eval`` and ``league``.

Each is a frozen dataclass that checks its own fields at construction (``rallysim.train.values``)
and names them with its section in errors (``ppo.gamma must be in [0, 1], got 5``). In YAML
each is a mapping under its name; on the command line each field is ``--set SECTION.FIELD=VALUE``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, ClassVar

from rallysim.train import values
from rallysim.train.values import Bound, above, at_least, within


@dataclass(frozen=True)
class PPOSettings:
    """PPO's rollout, update and networks (docs/reference.md §8: tanh MLP 64x64 actor and critic,
    log-std initialised at -0.5), shared by the SB3 and RLlib backends."""

    SECTION: ClassVar[str] = "ppo"

    n_envs: int = 64
    n_steps: int = 64
    batch_size: int = 1024
    n_epochs: int = 10
    target_kl: float | None = None
    learning_rate: float = 3e-4
    anneal_lr: bool = False  # decay the learning rate linearly to 0 over the budget
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    net_arch: tuple[int, ...] = (64, 64)
    activation: str = "tanh"
    log_std_init: float = -0.5
    # SB3 only: keep the Gaussian inside the action range (rallysim.train.action_range): the
    # weight of a penalty on the mean beyond it, and the log-std's upper bound at the budget's
    # end, lowered linearly from log_std_init (None: the log-std is only learned)
    mean_bound: float = 0.0
    log_std_end: float | None = None

    def __post_init__(self) -> None:
        if isinstance(self.net_arch, list):  # as YAML and to_dict() write it
            object.__setattr__(self, "net_arch", tuple(self.net_arch))
        values.check_fields(self, "ppo.", {"activation": ("tanh", "relu")}, _PPO_BOUNDS)
        if any(width < 1 for width in self.net_arch):
            raise ValueError(f"ppo.net_arch layer widths must be >= 1, got "
                             f"{list(self.net_arch)}")
        if self.log_std_end is not None and self.log_std_end > self.log_std_init:
            raise ValueError(f"ppo.log_std_end lowers the log-std from ppo.log_std_init: it "
                             f"must be <= {self.log_std_init}, got {self.log_std_end}")
        if self.n_envs * self.n_steps < 2:
            raise ValueError(f"a rollout (ppo.n_envs x ppo.n_steps) needs at least 2 decisions, "
                             f"got {self.n_envs} x {self.n_steps}")

    def sb3_kwargs(self) -> dict[str, Any]:
        """Stable-Baselines3 ``PPO``'s keyword arguments for these settings."""
        import torch

        from rallysim.train.torch_speed import SB3_ADAM_KWARGS

        activation = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[self.activation]
        lr0 = self.learning_rate
        learning_rate: Any = (lambda remaining: lr0 * remaining) if self.anneal_lr else lr0
        return {
            "n_steps": self.n_steps, "batch_size": self.batch_size, "n_epochs": self.n_epochs,
            "target_kl": self.target_kl, "learning_rate": learning_rate,
            "gamma": self.gamma, "gae_lambda": self.gae_lambda, "clip_range": self.clip_range,
            "ent_coef": self.ent_coef, "vf_coef": self.vf_coef,
            "max_grad_norm": self.max_grad_norm,
            "policy_kwargs": {"net_arch": {"pi": list(self.net_arch), "vf": list(self.net_arch)},
                              "activation_fn": activation, "log_std_init": self.log_std_init,
                              "optimizer_kwargs": dict(SB3_ADAM_KWARGS)},
        }


_PPO_BOUNDS: dict[str, Bound] = {
    "n_envs": at_least(1), "n_steps": at_least(1),
    # PPO normalises advantages over a minibatch, and over a rollout: both need two samples
    "batch_size": at_least(2),
    "n_epochs": at_least(1), "target_kl": above(0), "learning_rate": above(0),
    # a discount or GAE lambda above 1 lets returns grow without bound
    "gamma": within(0, 1), "gae_lambda": within(0, 1),
    "clip_range": above(0), "ent_coef": at_least(0), "vf_coef": at_least(0),
    "max_grad_norm": above(0), "mean_bound": at_least(0),
}


@dataclass(frozen=True)
class WarmStartSettings:
    """Behaviour cloning of the player's scripted controller before PPO (the low stage; not the
    paper's method): ``decisions`` of its play fitted for ``epochs``, then ``dagger`` rounds in
    which the clone plays a quarter as many decisions and the teacher labels them, then
    ``rally_dagger`` rounds of as many decisions inside the turn-based rally, each turn's goal
    drawn from the central ``rally_spread`` of the goal range."""

    SECTION: ClassVar[str] = "warm_start"

    teacher: str = "none"  # "scripted": the player's scripted controller; "none": no clone
    decisions: int = 524_288
    epochs: int = 60
    batch_size: int = 4096
    lr: float = 1e-3
    lr_decay: bool = False  # cosine decay of the clone's learning rate over each fit
    log_std: float = -1.5  # the actor's log-std once cloned (small: the clone is already good)
    dagger: int = 0
    rally_dagger: int = 0
    rally_spread: float = 0.5

    def __post_init__(self) -> None:
        values.check_fields(self, "warm_start.", {"teacher": ("none", "scripted")},
                            _WARM_BOUNDS)

    @property
    def enabled(self) -> bool:
        return self.teacher != "none"


_WARM_BOUNDS: dict[str, Bound] = {
    "decisions": at_least(1), "epochs": at_least(1), "batch_size": at_least(1),
    "lr": above(0), "dagger": at_least(0), "rally_dagger": at_least(0),
    "rally_spread": values.within(0, 1),
}


@dataclass(frozen=True)
class EvalSettings:
    """How the stage's deterministic policy is judged during and after training."""

    SECTION: ClassVar[str] = "eval"

    every: int = 500_000  # budget units between evaluations (0: only at the end)
    episodes: int = 500  # episodes (low) or rallies (high, mono) per evaluation
    seed: int = 12345

    def __post_init__(self) -> None:
        values.check_fields(self, "eval.", {}, {"every": at_least(0),
                                                "episodes": at_least(1), "seed": values.SEED})


@dataclass(frozen=True)
class LeagueSettings:
    """The compete stage's opponents (``rallysim.train.league``): frozen snapshots of the
    learner, a window of recent ones plus the latest, beside fixed anchor agents; or, with
    ``opponents`` set, a fixed pool and no snapshots (a best response)."""

    SECTION: ClassVar[str] = "league"

    snapshot_every: int = 40_000  # turns between snapshots of the learner
    win_threshold: float = 0.6  # a snapshot early once the learner wins this share of points
    win_points: int = 2000  # ... counted over at least this many training points
    window: int = 10  # recent snapshots kept in the pool beside the latest
    latest_ratio: float = 0.5  # share of games against the latest snapshot
    anchors: str = "scripted"  # comma-separated agents always in the pool ("none": none)
    anchor_ratio: float = 0.2  # share of games against the anchors
    # comma-separated agents or path prefixes: a fixed pool and no snapshots ("none": self-play)
    opponents: str = "none"
    max_decisions: int = 20_000  # per training game (lets between non-missing players)
    eval_opponents: str = "scripted,hrl"  # the point-win rates an evaluation reports
    rating_games: int = 8  # games per pair: the ladder's round-robin, a snapshot vs each rung
    rating_decisions: int = 5_000  # ... each stopped after this many decisions (by its score)
    ladder: str = "random,scripted,hrl,mono,fixed:6"  # the fixed reference ladder

    def __post_init__(self) -> None:
        values.check_fields(self, "league.", {}, _LEAGUE_BOUNDS)
        if self.latest_ratio + self.anchor_ratio > 1.0:
            raise ValueError("league.latest_ratio + league.anchor_ratio must be <= 1, got "
                             f"{self.latest_ratio} + {self.anchor_ratio}")

    @staticmethod
    def names(text: str) -> list[str]:
        """The agents a comma-separated setting names (``"none"``: none)."""
        return [n.strip() for n in text.split(",") if n.strip() and n.strip() != "none"]


_LEAGUE_BOUNDS: dict[str, Bound] = {
    "snapshot_every": at_least(1), "win_threshold": within(0, 1), "win_points": at_least(1),
    "window": at_least(0), "latest_ratio": within(0, 1), "anchor_ratio": within(0, 1),
    "max_decisions": at_least(1), "rating_games": at_least(0),
    "rating_decisions": at_least(1),
}


SECTIONS: dict[str, type] = {cls.SECTION: cls for cls in (PPOSettings, WarmStartSettings,
                                                          EvalSettings, LeagueSettings)}


def section_fields(name: str) -> tuple[str, ...]:
    return tuple(f.name for f in fields(SECTIONS[name]))
