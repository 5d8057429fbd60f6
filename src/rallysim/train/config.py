"""Training configuration: one dataclass, defaults per stage in ``configs/{stage}.yaml``.

Precedence: the stage's packaged YAML < the player's packaged YAML for that stage
(``configs/{stage}_humanlike.yaml``, HUMAN-LIKE only) < a user's YAML (``--config``) <
``--set key=value``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any, get_type_hints

import yaml

from rallysim.core.shuttle import SHUTTLE_MODELS

STAGES = ("low", "high", "mono")
CONFIG_DIR = Path(__file__).parent / "configs"
# the low stage's ``incoming`` values; a copy of envs.simple_return_v0.INCOMING (a test keeps
# them equal) because importing the environment here would load MuJoCo for every config read
INCOMING = ("serve", "mixed", "rally")
# seeds feed numpy's legacy seeding (below 2**32) after offsets such as the evaluation's
# + 1_000_003; the int32 range leaves room for those
SEED_MAX = 2**31 - 1


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
        # every value is checked here, so a bad one fails at construction (and at every
        # ``replace``), naming the field, instead of deep inside SB3 or after hours of training
        if isinstance(self.net_arch, list):  # as to_dict() writes it: keep the config hashable
            object.__setattr__(self, "net_arch", tuple(self.net_arch))
        for f in fields(self):
            _check_type(f.name, _FIELD_KINDS[f.name], getattr(self, f.name))
        for name, valid in _CHOICES.items():
            if getattr(self, name) not in valid:
                raise ValueError(f"{name} must be one of {', '.join(map(repr, valid))}, got "
                                 f"{getattr(self, name)!r}")
        if self.env == "humanlike" and self.stage == "mono":
            raise ValueError("the HUMAN-LIKE player has low and high stages (no monolithic)")
        # decisions = 0 with a warm start: the clone is the policy (no PPO after it)
        floor = 0 if self.warm_start != "none" else 1
        if self.decisions < floor:
            raise ValueError(f"decisions must be >= {floor}, got {self.decisions}")
        if self.n_envs * self.n_steps < 2:
            raise ValueError(f"a rollout (n_envs x n_steps) needs at least 2 decisions, got "
                             f"{self.n_envs} x {self.n_steps}")
        for name, (ok, bounds) in _BOUNDS.items():
            value = getattr(self, name)
            if value is not None and not ok(value):
                raise ValueError(f"{name} must be {bounds}, got {value!r}")
        if any(width < 1 for width in self.net_arch):
            raise ValueError(f"net_arch layer widths must be >= 1, got {list(self.net_arch)}")
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


def _at_least(low: float) -> tuple[Callable[[Any], bool], str]:
    return (lambda v: v >= low), f">= {low:g}"


def _above(low: float) -> tuple[Callable[[Any], bool], str]:
    return (lambda v: v > low), f"> {low:g}"


def _within(low: float, high: float) -> tuple[Callable[[Any], bool], str]:
    return (lambda v: low <= v <= high), f"in [{low:g}, {high:g}]"


_CHOICES: dict[str, tuple[str, ...]] = {
    "stage": STAGES, "env": ("simple", "humanlike"), "shuttle": tuple(SHUTTLE_MODELS),
    "activation": ("tanh", "relu"), "incoming": INCOMING, "warm_start": ("none", "scripted"),
}
# the range of every bounded number (``decisions`` depends on warm_start: __post_init__);
# a value of None (target_kl) means "off" and is not bounded
_BOUNDS: dict[str, tuple[Callable[[Any], bool], str]] = {
    "seed": (lambda v: 0 <= v <= SEED_MAX, f"in [0, {SEED_MAX}]"),
    "eval_seed": (lambda v: 0 <= v <= SEED_MAX, f"in [0, {SEED_MAX}]"),
    "n_envs": _at_least(1), "n_steps": _at_least(1),
    # PPO normalises advantages over a minibatch, and over a rollout: both need two samples
    "batch_size": _at_least(2),
    "n_epochs": _at_least(1), "target_kl": _above(0), "learning_rate": _above(0),
    # a discount or GAE lambda above 1 lets returns grow without bound
    "gamma": _within(0, 1), "gae_lambda": _within(0, 1),
    "clip_range": _above(0), "ent_coef": _at_least(0), "vf_coef": _at_least(0),
    "max_grad_norm": _above(0), "torch_threads": _at_least(1),
    "eval_every": _at_least(0),  # 0: evaluate only at the end
    "eval_episodes": _at_least(1), "checkpoint_every": _at_least(1),
    "warm_start_decisions": _at_least(1), "warm_start_epochs": _at_least(1),
    "warm_start_dagger": _at_least(0), "warm_start_batch_size": _at_least(1),
}


def _kind(hint: Any) -> str:
    """The check a field's annotation asks for: int, float, bool, str, float|None, widths."""
    if hint in (int, float, bool, str):
        return hint.__name__
    if hint == float | None:
        return "float|None"
    if hint == tuple[int, ...]:
        return "widths"
    raise TypeError(f"TrainConfig has no check for the annotation {hint!r}")


_FIELD_KINDS = {name: _kind(hint) for name, hint in get_type_hints(TrainConfig).items()}


def _check_type(name: str, kind: str, value: Any) -> None:
    # bool is an int subclass in Python: True must not pass as n_envs=1
    is_int = isinstance(value, int) and not isinstance(value, bool)
    if kind == "int" and not is_int:
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if kind in ("float", "float|None") and not (kind == "float|None" and value is None):
        if not (is_int or isinstance(value, float)):
            raise ValueError(f"{name} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value!r}")
    if kind == "bool" and not isinstance(value, bool):
        raise ValueError(f"{name} must be true or false, got {value!r}")
    if kind == "str" and not (isinstance(value, str) and value):
        raise ValueError(f"{name} must be a non-empty string, got {value!r}")
    if kind == "widths" and not (isinstance(value, tuple) and all(
            isinstance(v, int) and not isinstance(v, bool) for v in value)):
        shown = list(value) if isinstance(value, tuple) else value
        raise ValueError(f"net_arch must be a list of integer layer widths, got {shown!r}")


def _coerce(key: str, value: Any) -> Any:
    """A value read from YAML or ``--set`` as its field's type where the text is unambiguous.

    PyYAML reads ``3e-4`` (no dot) and ``1e6`` as strings and ``2.0`` as a float; those are
    what a user means as a learning rate or a budget. Anything else passes unchanged, for
    ``TrainConfig`` to reject with the field's name."""
    kind = _FIELD_KINDS.get(key)
    if kind == "widths" and isinstance(value, list | tuple):
        return tuple(_as_int(v) for v in value)
    if kind == "int":
        return _as_int(value)
    if kind in ("float", "float|None") and isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def _as_int(value: Any) -> Any:
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            return value
    if isinstance(value, float) and value.is_integer():
        return int(value)
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
    # keys as text: a YAML key may be a number or null, which do not sort with strings
    unknown = sorted(map(str, set(values) - valid))
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
    except UnicodeDecodeError:
        raise ValueError(f"config file {source} is not text (UTF-8 YAML)") from None
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
        try:
            out[key.strip()] = yaml.safe_load(value)
        except yaml.YAMLError as err:
            problem = " ".join(str(err).split())  # PyYAML's message spans several lines
            raise ValueError(f"--set {key.strip()}: {value!r} is not a YAML value: "
                             f"{problem}") from None
    return out
