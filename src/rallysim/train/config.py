"""Training configuration: ``TrainConfig``, its top-level settings and three sections (``ppo``,
``warm_start``, ``eval``: ``rallysim.train.sections``), with defaults per stage in
``configs/{stage}.yaml``.

Precedence: the stage's packaged YAML < the player's packaged YAML for that stage
(``configs/{stage}_{player}.yaml``, where one exists) < a user's YAML (``--config``) <
``--set KEY=VALUE``.

A setting is named by its field, with its section before a dot: ``budget``, ``ppo.n_envs``,
``warm_start.dagger``. A YAML file may nest the sections (``ppo: {n_envs: 128}``) or write dotted
keys. The names from before the sections (``env``, ``decisions``, ``n_envs``,
``warm_start_dagger``, ``eval_episodes``, ...) still load, with a ``DeprecationWarning`` naming
the new one, so older YAML files, run records and shipped policies' metadata keep working.
"""

from __future__ import annotations

import difflib
import warnings
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from rallysim.core.shuttle import SHUTTLE_MODELS
from rallysim.train import stages, values
from rallysim.train.players import DEFAULT_PLAYER, PLAYERS
from rallysim.train.sections import (
    SECTIONS,
    EvalSettings,
    LeagueSettings,
    PPOSettings,
    WarmStartSettings,
)
from rallysim.train.values import SEED, SEED_MAX, Bound, at_least

__all__ = ["CONFIG_DIR", "INCOMING", "SEED_MAX", "STAGES", "RenamedSetting", "TrainConfig",
           "load_config", "parse_overrides", "setting_names"]

STAGES = stages.NAMES
CONFIG_DIR = Path(__file__).parent / "configs"
# the low stage's ``incoming`` values; a copy of envs.simple_return_v0.INCOMING (a test keeps
# them equal) because importing the environment here would load MuJoCo for every config read
INCOMING = ("serve", "mixed", "rally")
GOALS = ("uniform", "reachable")  # likewise envs.simple_return_v0.GOALS
REWARD_OPTIONS = ("returnable", "ready")  # likewise core.tasks.simple_return.REWARD_OPTIONS
BUDGET_UNIT = "budget_unit"  # written beside the budget; read back only to check it


class RenamedSetting(DeprecationWarning):
    """A setting given by its name from before the sections (``old``; now ``new``)."""

    def __init__(self, old: str, new: str) -> None:
        super().__init__(f"setting {old!r} is deprecated: use {new!r}")
        self.old, self.new = old, new


@dataclass(frozen=True)
class TrainConfig:
    """Everything that shapes one PPO training run of one stage."""

    stage: str = "low"
    player: str = DEFAULT_PLAYER  # "simple" or "humanlike" (low and high stages)
    shuttle: str = "paper"
    # in the stage's unit (``budget_unit``): decisions (low), turns (high), player-decisions
    # (mono); 0 with a warm start: the clone alone, no PPO
    budget: int = 3_000_000
    seed: int = 0
    checkpoint_every: int = 250_000  # budget units between checkpoints
    torch_threads: int = 1
    # high stage: the frozen low level (path prefix, pretrained or scripted; HUMAN-LIKE: also
    # "scripted" for AimedSwing)
    low_policy: str = "pretrained"
    # compete_mono stage: the Monolithic policy its actor starts from (path prefix, pretrained,
    # or none: random weights)
    init_policy: str = "pretrained"
    # low stage: what comes over ("serve", "mixed", "rally") and whether the player carries its
    # state from one episode to the next (the original builds) instead of a random start
    incoming: str = "serve"
    keep_bodies: bool = False
    # low stage, SIMPLE: the goals drawn ("uniform": SimpleReturn-v0's; "reachable": -v1's)
    goals: str = "uniform"
    # low stage, SIMPLE: the task's rewards for a shot the opponent can meet and for standing
    # ready when it lands (0: the paper's task)
    returnable: float = 0.0
    ready: float = 0.0
    # high stage: rallies per goal of the start's goal sweep (0: none, PPO starts at the
    # centre of the goal range), over goal_sweep_points goals per goal axis
    # (rallysim.train.goal_sweep)
    goal_sweep: int = 0
    goal_sweep_points: int = 9
    ppo: PPOSettings = field(default_factory=PPOSettings)
    warm_start: WarmStartSettings = field(default_factory=WarmStartSettings)
    eval: EvalSettings = field(default_factory=EvalSettings)
    league: LeagueSettings = field(default_factory=LeagueSettings)

    def __post_init__(self) -> None:
        # every value is checked here (and in the sections), so a bad one fails at
        # construction and at every ``replace``, naming the setting
        for name, cls in SECTIONS.items():
            value = getattr(self, name)
            if isinstance(value, Mapping):  # as to_dict() writes it
                object.__setattr__(self, name, _section(name, value))
            elif not isinstance(value, cls):
                raise ValueError(f"{name} must be a mapping of its settings, got {value!r}")
        values.check_fields(self, "", _CHOICES, _BOUNDS)
        stage = stages.by_name(self.stage)
        trains = [s.name for s in stages.STAGES.values() if self.player in s.players]
        if self.stage not in trains:
            raise ValueError(f"the {PLAYERS[self.player].label} player has "
                             f"{' and '.join(trains)} stages (no {stage.title})")
        # budget = 0 with a warm start: the clone is the policy (no PPO after it)
        floor = 0 if self.warm_start.enabled else 1
        if self.budget < floor:
            raise ValueError(f"budget ({stage.unit}) must be >= {floor}, got {self.budget}")
        if self.warm_start.enabled and not stage.warm_starts:
            starts = " and ".join(s.name for s in stages.STAGES.values() if s.warm_starts)
            raise ValueError(f"warm_start applies to the {starts} stage only")
        terms = [f"{n}={getattr(self, n)}" for n in REWARD_OPTIONS if getattr(self, n)]
        if terms and (self.stage != "low" or self.player != "simple"):
            raise ValueError(f"{' and '.join(terms)}: the SIMPLE low stage's reward options, "
                             f"not the {PLAYERS[self.player].label} {stage.name} stage's")
        if self.goal_sweep and not stage.sweeps_goals:
            raise ValueError(f"goal_sweep applies to the high stage only, got "
                             f"{self.goal_sweep} for the {stage.name} stage")
        if self.ppo.n_envs % stage.slots_per_env:
            raise ValueError(f"the {stage.name} stage needs ppo.n_envs divisible by "
                             f"{stage.slots_per_env} (one slot per rally-player pair), got "
                             f"{self.ppo.n_envs}")

    @property
    def budget_unit(self) -> str:
        """What one unit of ``budget`` is for this stage (one SB3 step)."""
        return stages.by_name(self.stage).unit

    def network(self) -> dict[str, Any]:
        """What a checkpoint must share with the run that resumes it."""
        return {"stage": self.stage, "player": self.player, "net_arch": list(self.ppo.net_arch),
                "activation": self.ppo.activation, "shuttle": self.shuttle}

    def ppo_kwargs(self) -> dict[str, Any]:
        """Stable-Baselines3 ``PPO``'s keyword arguments (``PPOSettings.sb3_kwargs``)."""
        return self.ppo.sb3_kwargs()

    def to_dict(self) -> dict[str, Any]:
        """Plain values, sections nested, the budget's unit beside it (YAML and JSON records)."""
        d = asdict(self)
        d["ppo"]["net_arch"] = list(self.ppo.net_arch)
        out: dict[str, Any] = {}
        for key, value in d.items():
            out[key] = value
            if key == "budget":
                out[BUDGET_UNIT] = self.budget_unit
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], warn: bool = True) -> TrainConfig:
        """A config from a record (``to_dict()``, a run's ``config.yaml``, a policy's metadata),
        in the current layout or the flat one from before the sections. ``warn``: a
        ``DeprecationWarning`` for every old name (off for records one cannot change)."""
        return _build(_flatten(data, "the record", warn))

    def __getattr__(self, name: str) -> Any:
        # the flat names from before the sections (config.n_envs, config.decisions, ...)
        new = LEGACY_KEYS.get(name)
        if new is None:
            raise AttributeError(f"'TrainConfig' object has no attribute {name!r}")
        warnings.warn(f"TrainConfig.{name} is deprecated: use TrainConfig.{new}",
                      DeprecationWarning, stacklevel=2)
        value: Any = self
        for part in new.split("."):
            value = getattr(value, part)
        return value


_CHOICES: dict[str, tuple[str, ...]] = {
    "stage": STAGES, "player": tuple(PLAYERS), "shuttle": tuple(SHUTTLE_MODELS),
    "incoming": INCOMING, "goals": GOALS,
}
_BOUNDS: dict[str, Bound] = {"seed": SEED, "torch_threads": at_least(1),
                             "checkpoint_every": at_least(1), "goal_sweep": at_least(0),
                             "goal_sweep_points": at_least(2), "returnable": at_least(0.0),
                             "ready": at_least(0.0)}
_TOP = tuple(f.name for f in fields(TrainConfig) if f.name not in SECTIONS)

# every setting's dotted name -> its kind (values.kind_of), generated from the dataclasses
KINDS: dict[str, str] = {
    **{name: kind for name, kind in values.kinds(TrainConfig).items() if kind != "section"},
    **{f"{section}.{name}": kind for section, cls in SECTIONS.items()
       for name, kind in values.kinds(cls).items()},
}


def setting_names() -> list[str]:
    """Every setting ``--set`` and a YAML file accept, as dotted names."""
    return list(KINDS)


def settings_help() -> str:
    """The settings by section, for ``rallysim train --help`` (generated from the fields)."""
    import textwrap

    groups = [", ".join(name for name in _TOP if name != "stage")]
    for section in SECTIONS:
        names = [key.partition(".")[2] for key in KINDS if key.startswith(f"{section}.")]
        groups.append(f"{section}.{{{', '.join(names)}}}")
    return "\n".join(["settings (--set KEY=VALUE, or keys of a --config YAML, where sections "
                      "may nest):",
                      *(textwrap.fill(g, 96, initial_indent="  ", subsequent_indent="    ")
                        for g in groups)])


# The flat names from before the sections, a fixed list: new fields get no flat name.
_OLD_PPO = ("n_envs", "n_steps", "batch_size", "n_epochs", "target_kl", "learning_rate",
            "anneal_lr", "gamma", "gae_lambda", "clip_range", "ent_coef", "vf_coef",
            "max_grad_norm", "net_arch", "activation", "log_std_init")
_OLD_WARM = ("decisions", "epochs", "log_std", "dagger", "batch_size", "lr_decay")
_OLD_EVAL = ("every", "episodes", "seed")
LEGACY_KEYS: dict[str, str] = {
    "env": "player", "decisions": "budget", "warm_start": "warm_start.teacher",
    **{name: f"ppo.{name}" for name in _OLD_PPO},
    **{f"warm_start_{name}": f"warm_start.{name}" for name in _OLD_WARM},
    **{f"eval_{name}": f"eval.{name}" for name in _OLD_EVAL},
}


def _flatten(data: Mapping[Any, Any], source: str, warn: bool = True) -> dict[str, Any]:
    """Settings as written (sections nested, dotted keys or the old flat names) -> one
    ``{dotted name: value}``; unknown names pass through for ``_build`` to refuse."""
    out: dict[str, Any] = {}
    given: dict[str, str] = {}  # dotted name -> the key that set it, to refuse a clash
    for key, value in data.items():
        name = str(key)  # a YAML key may be a number or null
        if name in SECTIONS and isinstance(value, Mapping):
            items = [(f"{name}.{sub}", name, v) for sub, v in value.items()]
        elif name in SECTIONS and name not in LEGACY_KEYS:
            raise ValueError(f"{name} is a section of settings: give a mapping in YAML or "
                             f"--set {name}.KEY=VALUE, got {value!r}")
        elif name in LEGACY_KEYS:
            new = LEGACY_KEYS[name]
            if warn:
                warnings.warn(RenamedSetting(name, new), stacklevel=3)
            items = [(new, name, value)]
        else:
            items = [(name, name, value)]
        for dotted, written, v in items:
            if dotted in given and given[dotted] != written:
                raise ValueError(f"{dotted} is set twice in {source} (as {given[dotted]} "
                                 f"and as {written})")
            given[dotted] = written
            out[dotted] = v
    return out


def _section(name: str, data: Mapping[Any, Any]) -> Any:
    """A section's dataclass from a mapping of its fields (unknown fields refused)."""
    settings = {f"{name}.{key}": value for key, value in data.items()}
    _refuse_unknown(settings)
    return SECTIONS[name](**{key.partition(".")[2]: values.coerce(KINDS[key], value)
                             for key, value in settings.items()})


def _refuse_unknown(settings: Mapping[str, Any]) -> None:
    unknown = sorted(set(settings) - set(KINDS) - {BUDGET_UNIT})
    if not unknown:
        return
    hints = []
    for key in unknown:
        close = difflib.get_close_matches(key, [*KINDS, *LEGACY_KEYS], n=1, cutoff=0.7)
        if close:
            hints.append(f"{key!r} (did you mean {LEGACY_KEYS.get(close[0], close[0])!r}?)")
        else:
            hints.append(repr(key))
    raise ValueError(f"unknown setting(s) {', '.join(hints)}; valid: {', '.join(KINDS)}")


def _build(settings: dict[str, Any]) -> TrainConfig:
    """A ``TrainConfig`` from ``{dotted name: value}`` (unknown names refused, text read as
    each field's type); unset fields keep ``TrainConfig``'s defaults."""
    _refuse_unknown(settings)
    unit = settings.pop(BUDGET_UNIT, None)
    top = {k: values.coerce(KINDS[k], v) for k, v in settings.items() if k in _TOP}
    parts: dict[str, dict[str, Any]] = {name: {} for name in SECTIONS}
    for key, value in settings.items():
        section, _, name = key.partition(".")
        if name:
            parts[section][name] = values.coerce(KINDS[key], value)
    config = TrainConfig(**top, **{name: SECTIONS[name](**kw) for name, kw in parts.items()})
    if unit is not None and unit != config.budget_unit:
        raise ValueError(f"budget_unit of the {config.stage} stage is {config.budget_unit!r}, "
                         f"got {unit!r}")
    return config


def load_config(stage: str, path: str | Path | None = None,
                overrides: Mapping[str, Any] | None = None) -> TrainConfig:
    """The stage's packaged defaults, updated by the YAML at ``path`` and ``overrides``
    (``{"ppo.n_envs": 128}``, ``{"ppo": {"n_envs": 128}}`` or an old flat name)."""
    if stage not in STAGES:
        raise ValueError(f"unknown stage {stage!r}; valid: {', '.join(STAGES)}")
    user = _flatten(_read_yaml(Path(path)), f"config file {path}") if path else {}
    extra = _flatten(overrides or {}, "the overrides")
    # the player's packaged settings sit between the stage's and the user's
    player = extra.get("player", user.get("player", DEFAULT_PLAYER))
    settings: dict[str, Any] = {"stage": stage}
    settings.update(_flatten(_read_yaml(CONFIG_DIR / f"{stage}.yaml"), stage, warn=False))
    overlay = CONFIG_DIR / f"{stage}_{player}.yaml"
    if isinstance(player, str) and player in PLAYERS and overlay.is_file():
        settings.update(_flatten(_read_yaml(overlay), overlay.name, warn=False))
    settings.update(user)
    settings.update(extra)
    _refuse_unknown(settings)
    if settings.get("stage") != stage:
        raise ValueError(f"config is for stage {settings.get('stage')!r}, not {stage!r}")
    return _build(settings)


def _read_yaml(source: Path) -> dict[str, Any]:
    import yaml  # the train extra's: this module also serves the CLI's help without it

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
    """``["ppo.n_envs=128", "ppo.net_arch=[64, 64]"]`` -> values parsed as YAML scalars or
    lists, keyed by the names as given (``load_config`` checks them)."""
    import yaml

    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set takes KEY=VALUE, got {item!r}")
        try:
            out[key.strip()] = yaml.safe_load(value)
        except yaml.YAMLError as err:
            problem = " ".join(str(err).split())  # PyYAML's message spans several lines
            raise ValueError(f"--set {key.strip()}: {value!r} is not a YAML value: "
                             f"{problem}") from None
    return out
