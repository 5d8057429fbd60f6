"""Training configuration: one dataclass, defaults per stage in ``configs/{stage}.yaml``.

Precedence: the stage's packaged YAML < the player's packaged YAML for that stage
(``configs/{stage}_humanlike.yaml``, HUMAN-LIKE only) < a user's YAML (``--config``) <
``--set key=value``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

import yaml

STAGES = ("low", "high", "mono")
CONFIG_DIR = Path(__file__).parent / "configs"


@dataclass(frozen=True)
class TrainConfig:
    """Everything that shapes one PPO training run of one stage."""

    stage: str = "low"
    env: str = "simple"  # the player, "simple" or "humanlike" (low and high stages)
    shuttle: str = "paper"
    decisions: int = 3_000_000  # budget, in SB3 steps (decisions; turns for the high level)
    # (0 with a warm start: the clone alone, no PPO)
    seed: int = 0
    # rollout and update (SB3 PPO)
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
    # networks (SPEC §8: tanh MLP 64x64 actor and critic, log-std initialised at -0.5)
    net_arch: tuple[int, ...] = (64, 64)
    activation: str = "tanh"
    log_std_init: float = -0.5
    # machinery
    torch_threads: int = 1
    eval_every: int = 500_000  # SB3 steps between evaluations (0: only at the end)
    eval_episodes: int = 500  # episodes (low) or rallies (high, mono) per evaluation
    eval_seed: int = 12345
    checkpoint_every: int = 250_000
    # high stage: the frozen low level (path prefix, pretrained or scripted; HUMAN-LIKE: also
    # "scripted" for AimedSwing)
    low_policy: str = "pretrained"
    # low stage: what comes over ("serve", "mixed", "rally") and whether the player carries its
    # state from one episode to the next (the original builds) instead of a random start
    incoming: str = "serve"
    keep_bodies: bool = False
    # low stage, not the paper's method: fit the actor to the scripted controller first
    # (behaviour cloning over warm_start_decisions of its play), then PPO as usual
    warm_start: str = "none"
    warm_start_decisions: int = 524_288
    warm_start_epochs: int = 60
    warm_start_log_std: float = -1.5
    warm_start_dagger: int = 0  # rounds of DAgger after the clone (a quarter of the data each)
    warm_start_batch_size: int = 4096
    warm_start_lr_decay: bool = False  # cosine decay of the clone's learning rate

    def __post_init__(self) -> None:
        if self.stage not in STAGES:
            raise ValueError(f"unknown stage {self.stage!r}; valid: {', '.join(STAGES)}")
        if self.env not in ("simple", "humanlike"):
            raise ValueError(f"env must be 'simple' or 'humanlike', got {self.env!r}")
        if self.env == "humanlike" and self.stage == "mono":
            raise ValueError("the HUMAN-LIKE player has low and high stages (no monolithic)")
        if self.activation not in ("tanh", "relu"):
            raise ValueError(f"activation must be 'tanh' or 'relu', got {self.activation!r}")
        for name in ("decisions", "n_envs", "n_steps", "batch_size", "n_epochs",
                     "eval_episodes", "checkpoint_every"):
            # decisions = 0 with a warm start: the clone is the policy (no PPO after it)
            floor = 0 if name == "decisions" and self.warm_start != "none" else 1
            if getattr(self, name) < floor:
                raise ValueError(f"{name} must be >= {floor}, got {getattr(self, name)}")
        if self.warm_start not in ("none", "scripted"):
            raise ValueError(f"warm_start must be 'none' or 'scripted', got {self.warm_start!r}")
        if self.warm_start != "none" and self.stage != "low":
            raise ValueError("warm_start applies to the low stage only")
        if self.stage == "mono" and self.n_envs % 2:
            raise ValueError("the mono stage needs an even n_envs (two players per rally)")

    def network(self) -> dict[str, Any]:
        """What a checkpoint must share with the run that resumes it."""
        return {"stage": self.stage, "env": self.env, "net_arch": list(self.net_arch),
                "activation": self.activation, "shuttle": self.shuttle}

    def ppo_kwargs(self) -> dict[str, Any]:
        import torch

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
                              "activation_fn": activation, "log_std_init": self.log_std_init},
        }

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["net_arch"] = list(self.net_arch)
        return d


def _coerce(key: str, value: Any) -> Any:
    if key == "net_arch":
        return tuple(int(v) for v in value)
    return value


def load_config(stage: str, path: str | Path | None = None,
                overrides: dict[str, Any] | None = None) -> TrainConfig:
    """The stage's packaged defaults, updated by the YAML at ``path`` and ``overrides``."""
    if stage not in STAGES:
        raise ValueError(f"unknown stage {stage!r}; valid: {', '.join(STAGES)}")
    valid = {f.name for f in fields(TrainConfig)}
    values: dict[str, Any] = {"stage": stage}
    user = _read_yaml(Path(path)) if path else {}
    # the HUMAN-LIKE player's packaged settings sit between the stage's and the user's
    env = (overrides or {}).get("env", user.get("env", "simple"))
    values.update(_read_yaml(CONFIG_DIR / f"{stage}.yaml"))
    player = CONFIG_DIR / f"{stage}_{env}.yaml"
    if env != "simple" and player.is_file():
        values.update(_read_yaml(player))
    values.update(user)
    values.update(overrides or {})
    unknown = sorted(set(values) - valid)
    if unknown:
        raise ValueError(f"unknown setting(s) {unknown}; valid: {sorted(valid)}")
    if values.get("stage") != stage:
        raise ValueError(f"config is for stage {values.get('stage')!r}, not {stage!r}")
    return replace(TrainConfig(), **{k: _coerce(k, v) for k, v in values.items()})


def _read_yaml(source: Path) -> dict[str, Any]:
    try:
        data = yaml.safe_load(source.read_text()) or {}
    except FileNotFoundError:
        raise FileNotFoundError(f"config file {source} does not exist") from None
    except yaml.YAMLError as err:
        raise ValueError(f"config file {source} is not valid YAML: {err}") from None
    if not isinstance(data, dict):
        raise ValueError(f"config file {source} must hold a mapping of settings")
    return data


def parse_overrides(items: list[str]) -> dict[str, Any]:
    """``["n_envs=128", "net_arch=[64, 64]"]`` -> values parsed as YAML scalars or lists."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--set takes KEY=VALUE, got {item!r}")
        out[key.strip()] = yaml.safe_load(value)
    return out
