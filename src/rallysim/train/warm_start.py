"""Optional behaviour-cloning warm start of a PPO actor-critic from a teacher controller.

Not the paper's method (it trained the low level from scratch): runs that use it must say so.
The teacher (e.g. ``ScriptedController().act_return``) plays ``decisions`` decisions of the
player's low-level task (``CloneTask``); the actor's mean is fitted to its actions (MSE; the
teacher's actions are already in [-1, 1]) and the critic to the discounted returns it earned,
so that PPO's first advantages are not noise that would undo the clone. With ``dagger`` > 0
rounds the clone then plays itself and the teacher labels the states it reaches (DAgger), so
that it also learns to recover from its own mistakes. With ``rally_dagger`` > 0 further rounds
the clone plays both players of the player's turn-based rally, on goals drawn at each turn from
the central ``rally_spread`` of the goal range, and the teacher labels every decision it makes
there: a rally's incoming shots are not the task's serves. The log-std is then set to ``log_std``
(small: the clone is already good). The settings are the ``warm_start`` section of the
training configuration (``rallysim.train.sections.WarmStartSettings``).

Resumable: given a ``WarmCheckpoint``, each round's dataset is saved once it is collected
(``data_{round}.{digest}.safetensors``) and the clone's state after every fitted epoch and
every evaluation (``warm_{n}.{json,safetensors}``: weights, the fit's Adam state, the random
generators and the results so far; ``rallysim.train.checkpoint.write_pair``). A warm start
killed at any moment and started again with the same settings resumes from the newest intact
state, redoing at most the collection or the epoch it was in, and ends with bit-identical
weights and results.
"""

from __future__ import annotations

import random
import re
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3 import PPO

from rallysim.policies.types import Policy
from rallysim.train import checkpoint as ckpt
from rallysim.train.sections import WarmStartSettings
from rallysim.train.torch_speed import ADAM_KWARGS

Evaluate = Callable[[Policy, int], dict[str, Any]]
Say = Callable[[str], None]

FORMAT = "rallysim-warm-start-checkpoint"
FORMAT_VERSION = 1
_STATE = re.compile(r"warm_(\d{6})\.json$")
_DATA_KEYS = ("obs", "act", "ret", "weight")
N_ENVS = 256  # environments the teacher and the clone play in, per round


@dataclass(frozen=True)
class CloneTask:
    """Where a warm start's teacher and clone play: the player's low-level task
    (``rallysim.train.stages.low.LowStage.clone_task``)."""

    player: str  # recorded with a saved warm start
    shuttle: str
    seed: int  # round k's episodes are drawn from seed + 7919 k
    make_env: Callable[..., Any]  # (environments, shuttle, **options) -> same-step vector env
    # the task's reward options (the SIMPLE task's returnable and ready), so that the critic
    # the clone fits is fitted to the rewards PPO trains on (its goals and incoming shots stay
    # the default task's)
    options: dict[str, Any] = field(default_factory=dict)


def teacher_dataset(teacher: Policy, task: CloneTask, n_envs: int, decisions: int, gamma: float,
                    seed: int, actor: Policy | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(obs, teacher's actions, discounted returns, sample weights) of complete episodes
    played by ``actor`` (default: the teacher itself) in ``task``'s env, ``n_envs`` at once,
    from ``seed``. A teacher with ``imitation_weights()`` weighs its last call's actions (per
    environment, or per environment and action); else all weigh 1."""
    env = task.make_env(n_envs, task.shuttle, **task.options)
    obs, _ = env.reset(seed=seed)
    steps = max(1, decisions // n_envs)
    all_obs = np.empty((steps, n_envs, obs.shape[1]), np.float32)
    all_act = np.empty((steps, n_envs, env.single_action_space.shape[0]), np.float32)
    rewards = np.empty((steps, n_envs))
    weights = np.ones((steps, n_envs, all_act.shape[2]), np.float32)
    dones = np.empty((steps, n_envs), bool)
    for t in range(steps):
        act, weights[t] = _labels(teacher, obs)
        all_obs[t], all_act[t] = obs, act
        if actor is not None:
            act = np.asarray(actor(obs), np.float32)
        obs, r, term, trunc, _ = env.step(act)
        rewards[t], dones[t] = r, term | trunc
    returns = np.zeros((steps, n_envs))
    valid = np.zeros((steps, n_envs), bool)  # inside an episode that ended before the cut
    running = np.zeros(n_envs)
    complete = np.zeros(n_envs, bool)
    for t in range(steps - 1, -1, -1):
        complete |= dones[t]
        running = rewards[t] + gamma * running * ~dones[t]
        returns[t], valid[t] = running, complete
    return all_obs[valid], all_act[valid], returns[valid].astype(np.float32), weights[valid]


def _labels(teacher: Policy, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The teacher's actions for ``obs`` and their sample weights: those of its
    ``imitation_weights()`` for this call (per observation, or per observation and action),
    else all 1."""
    act = np.asarray(teacher(obs), np.float32)
    weight = np.ones_like(act)
    weigh = getattr(teacher, "imitation_weights", None)
    if weigh is not None:
        w = np.asarray(weigh(), np.float32)
        weight[:] = w[:, None] if w.ndim == 1 else w
    return act, weight


class _RallyLabeller:
    """A rally's low level ``(observations, goals) -> actions`` that plays ``actor`` and keeps
    the teacher's label of each decision, in the low-level task's observations. A rally held
    still while the rest of its batch finishes a turn repeats its observation: that row is not
    kept again."""

    def __init__(self, teacher: Policy, actor: Policy, low_observations: Callable) -> None:
        self.teacher, self.actor, self.low_observations = teacher, actor, low_observations
        self.rows: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.kept = 0
        self._last: np.ndarray | None = None

    def __call__(self, obs: np.ndarray, goals: np.ndarray) -> np.ndarray:
        low = np.asarray(self.low_observations(obs, goals), np.float32)
        act, weight = _labels(self.teacher, low)
        moved = (np.ones(len(low), bool) if self._last is None or self._last.shape != low.shape
                 else np.any(low != self._last, axis=1))
        self._last = low
        self.rows.append((low[moved], act[moved], weight[moved]))
        self.kept += int(moved.sum())
        return np.asarray(self.actor(low), np.float32)


def rally_dataset(teacher: Policy, task: CloneTask, rows: int, seed: int, actor: Policy,
                  spread: float, n_rallies: int = N_ENVS // 2
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(obs, teacher's actions, returns, sample weights) of ``rows`` low-level decisions that
    ``actor`` makes for both players of ``task.player``'s turn-based rally (``n_rallies`` at
    once, cooperative rules, from ``seed``), each turn's goal drawn uniformly from the central
    ``spread`` of the goal range; whole batches are played and ``rows`` of their decisions
    drawn uniformly. A rally has no low-level return: those are NaN, which the critic's fit
    skips."""
    from rallysim.core.tasks.rally import RallyConfig
    from rallysim.eval.rally_eval import play_turns
    from rallysim.players import get_player

    player = get_player(task.player)
    rng = np.random.default_rng(seed)

    def goals(obs: np.ndarray) -> np.ndarray:
        return player.goal.from_action(rng.uniform(-spread, spread,
                                                   (len(obs), *player.goal.shape)))

    labeller = _RallyLabeller(teacher, actor, player.low_observations)
    rules = RallyConfig(shuttle=task.shuttle)
    batch = 0
    while labeller.kept < rows:
        play_turns(goals, labeller, n_rallies, seed + 104_729 * batch, rules, player=player)
        batch += 1
    # a uniform sample of what was played, not its first rows: those are the rallies' starts
    keep = np.sort(rng.choice(labeller.kept, rows, replace=False))
    obs, act, weight = (np.concatenate(parts)[keep] for parts in zip(*labeller.rows,
                                                                      strict=True))
    return obs, act, np.full(rows, np.nan, np.float32), weight


def _say_stderr(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


@dataclass
class WarmCheckpoint:
    """Where a warm start keeps its resumable state. ``say``: warnings (a skipped damaged
    state); ``note``: progress (where it resumed), or None for quiet; ``extra``: settings beyond
    ``behaviour_clone``'s own that the saved state must share (the evaluation's)."""

    folder: Path
    say: Say = _say_stderr
    note: Say | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    keep: int = 2


@dataclass
class _Progress:
    """Where a warm start stands: what a saved state records besides the tensors."""

    round: int = 0  # the round under way
    epoch: int = 0  # epochs of that round's fit done
    evaluated: bool = False  # that round's clone evaluated
    labelled: int = 0  # decisions labelled by the teacher so far
    rounds: list[dict[str, Any]] = field(default_factory=list)
    losses: dict[str, float] = field(
        default_factory=lambda: {"actor_mse": 0.0, "critic_mse": 0.0})
    elapsed_s: float = 0.0  # time spent in earlier processes
    seq: int = 0  # saves so far (names the state files)
    result: dict[str, Any] | None = None  # set when the warm start is done


def _teacher_name(teacher: Policy) -> str:
    return str(getattr(teacher, "__qualname__", type(teacher).__qualname__))


class _Store:
    """Saves and restores a warm start's progress, its datasets, the clone, its optimiser and
    every random generator that the rest of the run draws from."""

    def __init__(self, where: WarmCheckpoint, settings: dict[str, Any], policy: Any,
                 optimiser: Any, gen: torch.Generator) -> None:
        self.where, self.settings = where, ckpt.plain_json(settings)
        self.policy, self.optimiser, self.gen = policy, optimiser, gen
        self.data_files: list[dict[str, str]] = []

    def save_data(self, k: int, arrays: tuple[np.ndarray, ...]) -> None:
        from safetensors.numpy import save

        folder = self.where.folder
        folder.mkdir(parents=True, exist_ok=True)
        data = save({key: np.ascontiguousarray(a) for key, a in zip(_DATA_KEYS, arrays,
                                                                      strict=True)})
        digest = ckpt.sha256_bytes(data)
        name = f"data_{k:02d}.{digest[:16]}.safetensors"
        ckpt.atomic_write(folder / name, data, "warm.data")
        del self.data_files[k:]
        self.data_files.append({"file": name, "sha256": digest})

    def save(self, run: _Progress) -> None:
        run.seq += 1
        tensors = {f"policy.{k}": v.detach().cpu().numpy()
                   for k, v in self.policy.state_dict().items()}
        opt_tensors, opt_doc = ckpt.flatten_optimizer(self.optimiser.state_dict())
        tensors.update(opt_tensors)
        np_state = np.random.get_state()
        tensors["rng.generator"] = self.gen.get_state().numpy()
        tensors["rng.torch"] = torch.get_rng_state().numpy()
        tensors["rng.numpy"] = np.asarray(np_state[1])
        py_state = random.getstate()
        doc = {"format": FORMAT, "format_version": FORMAT_VERSION, "settings": self.settings,
               "seq": run.seq, "round": run.round, "epoch": run.epoch,
               "evaluated": run.evaluated, "labelled": run.labelled, "rounds": run.rounds,
               "losses": run.losses, "elapsed_s": run.elapsed_s, "result": run.result,
               "data": self.data_files, "optimizer": opt_doc,
               "rng": {"numpy": [np_state[0], *np_state[2:]],
                       "python": [py_state[0], list(py_state[1]), py_state[2]]}}
        folder = self.where.folder
        ckpt.write_pair(folder, f"warm_{run.seq:06d}", tensors, doc, "warm")
        ckpt.prune(folder, _STATE, self.where.keep, ("warm_", "data_"), _data_named)
        ckpt.crash_point("warm.saved")

    def restore(self) -> tuple[_Progress, list[tuple[np.ndarray, ...]]] | None:
        """Load the newest intact state into the clone, its optimiser and the generators;
        (the progress, the datasets), or None when there is none."""
        paths = ckpt.checkpoints(self.where.folder, _STATE)
        found: tuple[_Progress, list[tuple[np.ndarray, ...]]] | None = ckpt.newest_intact(
            paths, self._load, self.where.say)
        return found

    def _load(self, path: Path) -> tuple[_Progress, list[tuple[np.ndarray, ...]]]:
        doc, tensors = ckpt.read_pair(path, FORMAT, (FORMAT_VERSION,), _check_state,
                                      expect={"settings": self.settings})
        data = [self._read_data(path, entry) for entry in doc["data"]]
        ckpt.load_module(self.policy, tensors, path)
        try:
            self.gen.set_state(torch.from_numpy(np.array(tensors["rng.generator"])))
            torch.set_rng_state(torch.from_numpy(np.array(tensors["rng.torch"])))
            name, pos, has_gauss, cached = doc["rng"]["numpy"]
            np.random.set_state((name, np.array(tensors["rng.numpy"]), pos, has_gauss,
                                 cached))
            version, internal, gauss = doc["rng"]["python"]
            random.setstate((version, tuple(internal), gauss))
        except (KeyError, RuntimeError, ValueError, TypeError) as err:
            raise ckpt.CheckpointError(f"checkpoint {path}: its tensors or field rng do not "
                                       f"fit this warm start: {err}") from None
        ckpt.load_optimizer(self.optimiser, tensors, doc["optimizer"], path)
        self.data_files = list(doc["data"])
        run = _Progress(round=doc["round"], epoch=doc["epoch"], evaluated=doc["evaluated"],
                        labelled=doc["labelled"], rounds=doc["rounds"], losses=doc["losses"],
                        elapsed_s=float(doc["elapsed_s"]), seq=doc["seq"], result=doc["result"])
        return run, data

    @staticmethod
    def _read_data(path: Path, entry: dict[str, str]) -> tuple[np.ndarray, ...]:
        from safetensors.numpy import load

        file = path.with_name(entry["file"])
        raw = ckpt.read_named(path, file, "data", "dataset")
        if ckpt.sha256_bytes(raw) != entry["sha256"]:
            raise ckpt.CheckpointError(f"warm-start dataset {file} is corrupted (SHA-256 "
                                       f"differs from field data of {path.name})")
        try:
            arrays = load(raw)
            return tuple(arrays[key] for key in _DATA_KEYS)
        except Exception as err:  # safetensors raises its own error types
            raise ckpt.CheckpointError(f"warm-start dataset {file} is corrupted: {err}"
                                       ) from None


def _data_named(path: Path) -> list[str]:
    """The datasets a saved state needs (every one beside it when it cannot be read)."""
    try:
        doc = ckpt.read_json(path)
        return [str(entry["file"]) for entry in doc["data"]]
    except (ckpt.CheckpointError, KeyError, TypeError):
        return [p.name for p in path.parent.glob("data_*.safetensors")]


def _check_state(doc: dict[str, Any], path: Path) -> None:
    """The fields a warm start's resume reads, with their types."""
    req, count = ckpt.require, ckpt.require_count
    for name in ("seq", "round", "epoch", "labelled"):
        count(doc, name, path)
    named = _STATE.search(path.name)
    if named is None or int(named.group(1)) != doc["seq"]:
        raise ckpt.CheckpointError(f"checkpoint {path}: field seq = {doc['seq']} disagrees "
                                   "with its file name")
    req(doc, "evaluated", bool, path)
    req(doc, "elapsed_s", float, path)
    req(doc, "settings", dict, path)
    for i, row in enumerate(req(doc, "rounds", list, path)):
        if not isinstance(row, dict):
            raise ckpt.CheckpointError(f"checkpoint {path}: field rounds[{i}] must be object")
    losses = req(doc, "losses", dict, path)
    for key in losses:
        req(losses, key, float, path, "losses.")
    req(doc, "result", (dict, type(None)), path)
    for i, entry in enumerate(req(doc, "data", list, path)):
        if not isinstance(entry, dict):
            raise ckpt.CheckpointError(f"checkpoint {path}: field data[{i}] must be object")
        name = req(entry, "file", str, path, f"data[{i}].")
        req(entry, "sha256", str, path, f"data[{i}].")
        if Path(name).name != name or name.startswith("."):
            raise ckpt.CheckpointError(f"checkpoint {path}: field data[{i}].file must name a "
                                       f"file beside it, found {name!r}")
    if len(doc["data"]) != doc["round"] + 1:  # a round's data is saved before its state
        raise ckpt.CheckpointError(f"checkpoint {path}: field data lists {len(doc['data'])} "
                                   f"dataset(s) for round {doc['round']}")
    optimizer = req(doc, "optimizer", dict, path)
    req(optimizer, "state", dict, path, "optimizer.")
    req(optimizer, "param_groups", list, path, "optimizer.")
    rng = req(doc, "rng", dict, path)
    req(rng, "numpy", list, path, "rng.")
    req(rng, "python", list, path, "rng.")


def behaviour_clone(model: PPO, teacher: Policy, settings: WarmStartSettings, task: CloneTask,
                    evaluate: Evaluate | None = None,
                    checkpoint: WarmCheckpoint | None = None,
                    fitted: Callable[[int], None] | None = None) -> dict[str, Any]:
    """Fit ``model``'s actor mean and critic to ``teacher`` playing ``task`` as ``settings``
    say (``rallysim.train.sections.WarmStartSettings``: decisions, epochs, batch size, learning
    rate and its cosine decay to 5 % over each fit, DAgger rounds, the final log-std); return
    the final losses. ``evaluate``: called with the deterministic clone and the round (0: the
    clone) after the first fit and after every DAgger round; its results are returned under
    ``rounds`` with the decisions labelled so far (the clone's learning curve).
    ``checkpoint``: save the progress there and resume from what is saved there (see the
    module's docstring). ``fitted(done)``: called after every epoch with the epochs fitted so
    far over all rounds, of ``total_fit_epochs(settings)`` (progress lines)."""
    decisions, epochs, lr = settings.decisions, settings.epochs, settings.lr
    dagger_rounds, seed = settings.dagger, task.seed
    t0 = time.perf_counter()
    policy = model.policy
    optimiser = torch.optim.Adam(policy.parameters(), lr=lr, **ADAM_KWARGS)
    gen = torch.Generator().manual_seed(seed)

    def student(obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return model.policy.predict(obs, deterministic=True)[0]

    run = _Progress()
    data: list[tuple[np.ndarray, ...]] = []
    store = None
    if checkpoint is not None:
        # what a saved state must share with the run that resumes it (these names are those
        # of saved warm starts: changing one would refuse their resume)
        record = {"decisions": decisions, "epochs": epochs,
                  "batch_size": settings.batch_size, "lr": lr, "log_std": settings.log_std,
                  "shuttle": task.shuttle, "seed": seed, "player": task.player,
                  "dagger_rounds": dagger_rounds, "lr_decay": settings.lr_decay,
                  "gamma": float(model.gamma), "teacher": _teacher_name(teacher),
                  "evaluated": evaluate is not None,
                  "network": {k: list(v.shape) for k, v in policy.state_dict().items()},
                  **checkpoint.extra}
        if settings.rally_dagger:  # absent otherwise, so that earlier warm starts resume
            record.update(rally_rounds=settings.rally_dagger, rally_spread=settings.rally_spread)
        if task.options:  # likewise
            record["task_options"] = dict(task.options)
        store = _Store(checkpoint, record, policy, optimiser, gen)
        restored = store.restore()
        if restored is not None:
            run, data = restored
            if checkpoint.note is not None:
                where = ("done" if run.result is not None else
                         f"round {run.round} of {dagger_rounds}, {run.epoch} epoch(s) fitted")
                checkpoint.note(f"resuming the warm start from warm_{run.seq:06d}.json "
                                f"({where})")
            if run.result is not None:
                return run.result

    mark = t0  # the time up to which run.elapsed_s counts

    def save() -> None:
        nonlocal mark
        if store is not None:
            now = time.perf_counter()
            run.elapsed_s, mark = run.elapsed_s + now - mark, now
            store.save(run)

    # round 0: the teacher plays; then the clone, in the task, then in the rally
    for k in range(run.round, dagger_rounds + settings.rally_dagger + 1):
        run.round = k
        size = decisions if k == 0 else max(N_ENVS, decisions // 4)
        if len(data) <= k:
            if k > dagger_rounds:
                data.append(rally_dataset(teacher, task, size, seed + 7919 * k, student,
                                          settings.rally_spread))
                run.labelled += size
            else:
                data.append(teacher_dataset(teacher, task, N_ENVS, size, model.gamma,
                                            seed + 7919 * k, actor=student if k else None))
                run.labelled += max(1, size // N_ENVS) * N_ENVS  # whole batch steps are played
            run.epoch, run.evaluated = 0, False
            if store is not None:
                store.save_data(k, data[k])
            save()
        fit_epochs = _fit_epochs(epochs, k)
        earlier = sum(_fit_epochs(epochs, r) for r in range(k))  # fitted in earlier rounds

        def epoch_done(epoch: int, losses: dict[str, float], earlier: int = earlier) -> None:
            run.epoch, run.losses = epoch + 1, losses
            save()
            if fitted is not None:
                fitted(earlier + epoch + 1)

        if run.epoch < fit_epochs:
            _fit(policy, optimiser, gen, data, fit_epochs, settings.batch_size, lr,
                 settings.lr_decay, start=run.epoch, epoch_done=epoch_done)
        if evaluate is not None and not run.evaluated:
            run.rounds.append({"round": k, "labelled_decisions": run.labelled, **run.losses,
                               **evaluate(student, k)})
            run.evaluated = True
            save()
    with torch.no_grad():
        policy.log_std.fill_(settings.log_std)
    elapsed = run.elapsed_s + time.perf_counter() - mark
    out: dict[str, Any] = {"samples": float(sum(len(d[0]) for d in data)), **run.losses,
                           "wall_s": round(elapsed, 2)}
    if evaluate is not None:
        out["rounds"] = run.rounds
    run.result = out
    save()
    return out


def _fit_epochs(epochs: int, round_: int) -> int:
    """Epochs of round ``round_``'s fit: all of them for the teacher's data (round 0), half as
    many for each DAgger round's."""
    return epochs if round_ == 0 else max(1, epochs // 2)


def total_fit_epochs(settings: WarmStartSettings) -> int:
    """Epochs a whole warm start fits, over all its rounds."""
    return sum(_fit_epochs(settings.epochs, r)
               for r in range(settings.dagger + settings.rally_dagger + 1))


def _critic_loss(value: Any, target: Any) -> Any:
    """The critic's squared error over the samples with a return (a rally's have none)."""
    known = torch.isfinite(target)
    if bool(known.all()):
        return torch.mean((value - target) ** 2)
    if not bool(known.any()):
        return value.sum() * 0.0
    return torch.mean((value[known] - target[known]) ** 2)


def _fit(policy: Any, optimiser: Any, gen: Any, data: list[tuple[np.ndarray, ...]],
         epochs: int, batch_size: int, lr: float, lr_decay: bool, start: int = 0,
         epoch_done: Callable[[int, dict[str, float]], None] | None = None
         ) -> dict[str, float]:
    """Fit epochs ``start`` .. ``epochs`` - 1; ``epoch_done(epoch, losses)`` after each."""
    o = torch.as_tensor(np.concatenate([d[0] for d in data]))
    a = torch.as_tensor(np.concatenate([d[1] for d in data]))
    g = torch.as_tensor(np.concatenate([d[2] for d in data]))[:, None]
    w = torch.as_tensor(np.concatenate([d[3] for d in data]))  # (samples, actions)
    actor_loss = critic_loss = torch.zeros(())
    losses = {"actor_mse": 0.0, "critic_mse": 0.0}
    for epoch in range(start, epochs):
        if lr_decay:
            for group in optimiser.param_groups:
                group["lr"] = lr * (0.05 + 0.475 * (1.0 + np.cos(np.pi * epoch / epochs)))
        for idx in torch.randperm(len(o), generator=gen).split(batch_size):
            features = policy.extract_features(o[idx])
            latent_pi, latent_vf = policy.mlp_extractor(features)
            mean = policy.action_net(latent_pi)
            value = policy.value_net(latent_vf)
            actor_loss = torch.mean(w[idx] * (mean - a[idx]) ** 2)
            critic_loss = _critic_loss(value, g[idx])
            optimiser.zero_grad()
            (actor_loss + 0.5 * critic_loss).backward()
            optimiser.step()
        losses = {"actor_mse": actor_loss.item(), "critic_mse": critic_loss.item()}
        if epoch_done is not None:
            epoch_done(epoch, losses)
    return losses
