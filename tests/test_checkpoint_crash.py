"""Lost work (issue 17): a run killed (SIGKILL) at each of its write points, in PPO and in the
warm start, resumes from the newest intact checkpoint and loses at most one interval; a warm
start resumed after any number of kills ends bit-identical to an uninterrupted one; damaged
checkpoint JSONs are refused with the file and the field named, and resume falls back past
them to an older intact checkpoint.

The killed runs are forked from a forkserver that has already imported torch, so that each
costs its training work, not a fresh interpreter's imports."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from rallysim.policies.mlp import load_policy
from rallysim.train import checkpoint as ckpt
from rallysim.train.config import load_config
from rallysim.train.runner import build_model, train_stage

pytestmark = pytest.mark.skipif(sys.platform == "win32",
                                reason="needs SIGKILL and the forkserver start method")

TINY = {"ppo.n_envs": 16, "ppo.n_steps": 32, "ppo.batch_size": 256, "ppo.n_epochs": 2,
        "eval.episodes": 8, "eval.every": 0, "checkpoint_every": 1024}  # 512 per rollout
# three rounds of a clone (round 0, then two DAgger rounds), PPO after it
WARM = {**TINY, "budget": 1024, "warm_start.teacher": "scripted",
        "warm_start.decisions": 16384, "warm_start.epochs": 2, "warm_start.dagger": 2,
        "warm_start.lr_decay": True}


def _cli_args(out: Path, overrides: dict) -> list[str]:
    sets = [f"{k}={str(v).lower() if isinstance(v, bool) else v}" for k, v in overrides.items()
            if k != "budget"]
    return ["train", "low", "--out", str(out), "--budget", str(overrides["budget"]),
            "--set", *sets]


def _train_until_killed(argv: list[str], crash_at: str, log: str) -> None:
    """The child: ``rallysim train`` with the crash hook set, its output into ``log``."""
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.environ[ckpt.CRASH_AT] = crash_at
    from rallysim.cli import main

    sys.exit(main(argv))


@pytest.fixture(scope="module")
def killed_run():
    """``run(out, overrides, crash_at) -> log``: train until the process kills itself at the
    write point ``crash_at`` (``LABEL:N``), asserting that it did."""
    ctx = multiprocessing.get_context("forkserver")
    # torch._dynamo: imported on the first optimiser, the largest part of a child's start
    ctx.set_forkserver_preload(["torch", "torch._dynamo", "stable_baselines3", "rallysim.cli",
                                "rallysim.train.runner", "rallysim.train.warm_start"])
    count = [0]

    def run(out: Path, overrides: dict, crash_at: str) -> str:
        count[0] += 1
        log = out.parent / f"{out.name}.{count[0]}.log"
        proc = ctx.Process(target=_train_until_killed,
                           args=(_cli_args(out, overrides), crash_at, str(log)))
        proc.start()
        proc.join(120)
        text = log.read_text()
        assert proc.exitcode == -signal.SIGKILL, f"not killed at {crash_at}:\n{text}"
        return text

    return run


def _newest(folder: Path, pattern: str = "step_*.json") -> tuple[str | None, dict | None]:
    found = sorted(folder.glob(pattern))
    return (found[-1].name, json.loads(found[-1].read_text())) if found else (None, None)


def _assert_tidy(folder: Path) -> None:
    """Every tensor file is named by a checkpoint JSON; no temporary file is left."""
    named = {json.loads(p.read_text())["weights"] for p in folder.glob("*.json")}
    files = {p.name for p in folder.iterdir() if p.is_file()}
    assert files - named == {p.name for p in folder.glob("*.json")}


def _layers(prefix: Path) -> list[np.ndarray]:
    """An exported policy's weights, biases and log-std."""
    policy = load_policy(prefix)
    return [x for layer in policy.layers for x in layer] + [policy.log_std]


def _assert_same(a: list[np.ndarray], b: list[np.ndarray]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


@pytest.mark.slow  # kills
def test_ppo_killed_at_every_write_point_resumes_losing_at_most_one_interval(tmp_path,
                                                                            killed_run):
    out = tmp_path / "run"
    budget = {**TINY, "budget": 3072}  # saves at 1024, 2048, 3072, then 3072 again (final)
    folder = out / "checkpoints"

    # the second save's tensors written under their temporary name: the run had 2048 done and
    # keeps 1024, one interval lost
    killed_run(out, budget, "checkpoint.tensors.tmp:2")
    assert _newest(folder)[1]["decisions"] == 2048 - budget["checkpoint_every"]
    assert list(folder.glob(".*.tmp"))
    # tensors in place, JSON not written; then the JSON written, not renamed
    for crash in ("checkpoint.tensors:1", "checkpoint.json.tmp:1"):
        log = killed_run(out, budget, crash)
        assert "resuming low from step_000000001024.json (1,024 decisions done)" in log
        name, doc = _newest(folder)
        assert (name, doc["decisions"]) == ("step_000000001024.json", 1024)
        ckpt.read_checkpoint(folder / name)  # intact
    # the final save repeats step 3072 in the same process: killed between its two writes,
    # the step's JSON still names its complete first tensor file
    killed_run(out, budget, "checkpoint.tensors:3")
    name, doc = _newest(folder)
    assert (name, doc["decisions"]) == ("step_000000003072.json", 3072)
    ckpt.read_checkpoint(folder / name)
    # a new process repeats the final save: killed before the rename, after it, after pruning,
    # and after exporting the policy with curve.json not yet in place
    for crash in ("checkpoint.json.tmp:1", "checkpoint.json:1", "checkpoint.saved:1",
                  "curve.tmp:1"):
        log = killed_run(out, budget, crash)
        assert "resuming low from step_000000003072.json (3,072 decisions done)" in log
        ckpt.read_checkpoint(folder / _newest(folder)[0])
    assert not (out / "curve.json").exists() and (out / "policy.json").exists()
    exported = _layers(out / "policy")

    curve = train_stage(load_config("low", None, budget), out, progress=False)
    assert curve["steps"] == 3072 and (out / "curve.json").exists()
    _assert_tidy(folder)
    assert len(list(folder.glob("*.json"))) == 3  # the newest three steps, kept
    # no training after 3072: what the last kills left is what the run exports
    _assert_same(_layers(out / "policy"), exported)


@pytest.mark.slow  # kills
def test_warm_start_killed_at_every_write_point_resumes_bit_identical(tmp_path, killed_run):
    reference = train_stage(load_config("low", None, WARM), tmp_path / "reference",
                            progress=False)
    out = tmp_path / "run"
    warm = out / "checkpoints" / "warm_start"
    # saves of the warm start: 1 round 0's data, 2-3 its two epochs, 4 its evaluation,
    # 5-7 round 1 (data, one epoch, evaluation), 8-10 round 2, 11 done

    killed_run(out, WARM, "warm.data.tmp:1")  # round 0's data written, not renamed
    assert _newest(warm, "warm_*.json") == (None, None)
    killed_run(out, WARM, "warm.tensors:3")  # epoch 2's state: tensors only
    assert _newest(warm, "warm_*.json")[0] == "warm_000002.json"
    log = killed_run(out, WARM, "warm.data:1")  # round 1's data in place, not yet recorded
    assert "resuming the warm start from warm_000002.json (round 0 of 2, 1 epoch(s) fitted)" \
        in log
    assert _newest(warm, "warm_*.json")[0] == "warm_000004.json"
    assert len(list(warm.glob("data_01.*"))) == 1
    killed_run(out, WARM, "warm.json.tmp:2")  # round 1's epoch: JSON not renamed
    assert _newest(warm, "warm_*.json")[0] == "warm_000005.json"
    killed_run(out, WARM, "warm.json:4")  # round 2's epoch: renamed, not pruned
    name, doc = _newest(warm, "warm_*.json")
    assert (name, doc["round"], doc["epoch"]) == ("warm_000009.json", 2, 1)

    # a damaged newest state: skipped with a line saying why, the one before it resumed
    tensors = warm / doc["weights"]
    data = tensors.read_bytes()
    tensors.write_bytes(data[:-1] + bytes([data[-1] ^ 0xFF]))
    log = killed_run(out, WARM, "warm.saved:3")  # saves 9, 10 and 11 (done) again
    assert "skipping checkpoint warm_000009.json: checkpoint tensors" in log
    assert "resuming the warm start from warm_000008.json" in log
    assert _newest(warm, "warm_*.json")[1]["result"] is not None

    # the settings a saved warm start was made with are not silently mixed with others
    with pytest.raises(ckpt.CheckpointMismatch, match="settings"):
        train_stage(load_config("low", None, {**WARM, "warm_start.epochs": 3}), out,
                    progress=False)
    # the hand-over to PPO: its first checkpoint half written, then written
    killed_run(out, WARM, "checkpoint.tensors:1")
    assert _newest(out / "checkpoints")[0] is None
    log = killed_run(out, WARM, "checkpoint.json:1")
    assert "resuming the warm start from warm_000011.json (done)" in log
    assert _newest(out / "checkpoints")[1]["decisions"] == 1024 and warm.is_dir()

    curve = train_stage(load_config("low", None, WARM), out, progress=False)
    assert not warm.exists()  # superseded by the PPO checkpoint
    _assert_tidy(out / "checkpoints")
    # as JSON text: equal NaNs (an evaluation without hits has no error to average) compare equal
    strip = lambda d: json.dumps({k: v for k, v in d.items() if k != "wall_s"})  # noqa: E731
    assert strip(curve["warm_start"]) == strip(reference["warm_start"])
    assert strip(curve["final"]) == strip(reference["final"])
    assert len(curve["warm_start"]["rounds"]) == 3
    _assert_same(_layers(out / "policy"), _layers(tmp_path / "reference" / "policy"))


# --- damaged checkpoints, in process -------------------------------------------------------

@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """A run folder with three checkpoints of one tiny model (512, 1024, 1536 decisions)."""
    out = tmp_path_factory.mktemp("saved")
    config = load_config("low", None, {**TINY, "budget": 512})
    model = build_model(config, out)
    meta = {"stage": "low", "network": config.network(), "curve": {"evals": [], "rollouts": []}}
    for step in (512, 1024, 1536):
        model.num_timesteps = step
        ckpt.save_checkpoint(out, model, meta)
    return out, config


def _copy_run(saved, tmp_path: Path) -> Path:
    import shutil

    run = tmp_path / "run"
    shutil.copytree(saved[0], run)
    return run


def _rewrite(path: Path, doc: dict, reseal: bool = True) -> None:
    if reseal:  # a valid checksum: the fields themselves must be checked
        doc["meta_sha256"] = ckpt.meta_digest(doc)
    path.write_text(json.dumps(doc))


BAD_FIELDS = [
    ("a list", lambda d: [d], "must hold a JSON object, found a list"),
    ("no decisions", lambda d: {k: v for k, v in d.items() if k != "decisions"},
     "field decisions is missing"),
    ("decisions a string", lambda d: {**d, "decisions": "1536"},
     "field decisions must be integer, found string"),
    ("decisions 1e18", lambda d: {**d, "decisions": 1e18},
     "field decisions must be integer, found number"),
    ("decisions 10**18", lambda d: {**d, "decisions": 10**18}, "field decisions = 10"),
    ("decisions -5", lambda d: {**d, "decisions": -5}, "field decisions = -5 is outside"),
    ("decisions true", lambda d: {**d, "decisions": True}, "field decisions must be integer"),
    ("decisions off its name", lambda d: {**d, "decisions": 1024},
     "field decisions = 1024 disagrees with its file name"),
    ("optimizer a list", lambda d: {**d, "optimizer": []}, "field optimizer must be object"),
    ("no param groups", lambda d: {**d, "optimizer": {"state": {}}},
     "field optimizer.param_groups is missing"),
    ("evals not a list", lambda d: {**d, "curve": {"evals": {}}}, "field curve.evals must be"),
    ("weights elsewhere", lambda d: {**d, "weights": "../policy.safetensors"},
     "field weights must name a file beside it"),
    ("weights a number", lambda d: {**d, "weights": 3}, "field weights must be string"),
]


@pytest.mark.parametrize("change, message", [(c, m) for _, c, m in BAD_FIELDS],
                         ids=[name for name, _, _ in BAD_FIELDS])
def test_bad_checkpoint_fields_are_refused_naming_file_and_field(saved, tmp_path, change,
                                                                 message):
    path = _copy_run(saved, tmp_path) / "checkpoints" / "step_000000001536.json"
    doc = change(json.loads(path.read_text()))
    if isinstance(doc, dict):
        _rewrite(path, doc)
    else:
        path.write_text(json.dumps(doc))
    with pytest.raises(ckpt.CheckpointError) as err:
        ckpt.read_checkpoint(path)
    assert message in str(err.value) and str(path) in str(err.value)


def test_bad_utf8_checksums_and_optimizer_layout_are_refused(saved, tmp_path):
    folder = _copy_run(saved, tmp_path) / "checkpoints"
    path = folder / "step_000000001536.json"
    doc = json.loads(path.read_text())
    path.write_bytes(path.read_bytes().replace(b'"stage"', b'"st\xffge"'))
    with pytest.raises(ckpt.CheckpointError, match="not valid UTF-8 at byte"):
        ckpt.read_checkpoint(path)
    # a field changed without its checksum: the metadata is checksummed too
    _rewrite(path, {**doc, "curve": {"evals": [], "rollouts": [], "train_wall_s": 9.0}},
             reseal=False)
    with pytest.raises(ckpt.CheckpointError, match="field meta_sha256"):
        ckpt.read_checkpoint(path)
    # an optimiser slot whose tensor the tensor file lacks
    doc["optimizer"]["state"]["0"] = {"bogus": "tensor"}
    _rewrite(path, doc)
    config = saved[1]
    model = build_model(config, tmp_path)
    loaded, tensors = ckpt.read_checkpoint(path)
    with pytest.raises(ckpt.CheckpointError, match=r"field optimizer.state.0.bogus names tensor"):
        ckpt.restore(model, loaded, tensors, path)


def test_resume_falls_back_to_the_newest_intact_checkpoint(saved, tmp_path):
    run = _copy_run(saved, tmp_path)
    folder = run / "checkpoints"
    config = saved[1]
    expect = {"stage": "low", "network": config.network()}
    newest = folder / "step_000000001536.json"
    tensors = folder / json.loads(newest.read_text())["weights"]
    tensors.write_bytes(tensors.read_bytes()[:-50])  # truncated by a dying disk
    (folder / "step_000000001024.json").write_bytes(b"\x00" * 30)  # a zeroed block
    said: list[str] = []
    model = build_model(config, tmp_path)
    path, doc = ckpt.resume(model, run, expect, said.append)
    assert (path.name, doc["decisions"], model.num_timesteps) == (
        "step_000000000512.json", 512, 512)
    assert said[0].startswith("skipping checkpoint step_000000001536.json: checkpoint tensors")
    assert said[1].startswith("skipping checkpoint step_000000001024.json: checkpoint")
    assert said[2] == ("resuming from the newest intact checkpoint, step_000000000512.json, "
                       "instead")
    # another run's checkpoint is refused outright, not skipped
    with pytest.raises(ckpt.CheckpointMismatch, match="made with network"):
        ckpt.resume(model, run, {**expect, "network": {**config.network(), "net_arch": [8]}},
                    said.append)
    (folder / "step_000000000512.json").write_text("[]")
    with pytest.raises(ckpt.CheckpointError, match=r"no intact checkpoint in .*--restart"):
        ckpt.resume(model, run, expect, said.append)
    assert ckpt.remove_checkpoints(run) == 3 and not folder.exists()


def _forge_tensor(path: Path, name: str, value: np.ndarray) -> None:
    """Replace tensor ``name`` of checkpoint ``path`` and recompute both digests: only a
    forged or hand-edited file has valid checksums and tensors that do not fit."""
    from safetensors.numpy import load, save

    doc = json.loads(path.read_text())
    weights = path.with_name(doc["weights"])
    tensors = load(weights.read_bytes())
    tensors[name] = value
    data = save(tensors)
    weights.write_bytes(data)
    doc["weights_sha256"] = ckpt.sha256_bytes(data)
    _rewrite(path, doc)


def test_tensors_of_the_wrong_shape_are_refused_in_one_line_at_load(saved, tmp_path):
    run = _copy_run(saved, tmp_path)
    config = saved[1]
    expect = {"stage": "low", "network": config.network()}
    model = build_model(config, tmp_path)
    sum(p.sum() for p in model.policy.parameters()).backward()
    model.policy.optimizer.step()  # Adam's moments exist from the first update on
    model.num_timesteps = 2048
    newest = ckpt.save_checkpoint(run, model, {**expect, "curve": {"evals": [], "rollouts": []}})
    doc, intact = ckpt.read_checkpoint(newest)
    assert doc["optimizer"]["state"]["0"]["exp_avg"] == "tensor"
    _forge_tensor(newest, "optimizer.0.exp_avg", np.zeros((3, 3), np.float32))
    said: list[str] = []
    fresh = build_model(config, tmp_path)
    path, _ = ckpt.resume(fresh, run, expect, said.append)
    assert said == [f"skipping checkpoint step_000000002048.json: checkpoint {newest}: tensor "
                    "optimizer.0.exp_avg has shape (3, 3), this network's is (3,)",
                    "resuming from the newest intact checkpoint, step_000000001536.json, "
                    "instead"]
    assert (path.name, fresh.num_timesteps) == ("step_000000001536.json", 1536)
    # a step count holds one value; the policy's tensors are checked the same way
    for change, line in [
            ({"optimizer.0.step": np.zeros(2, np.float32)},
             "tensor optimizer.0.step has shape (2,), this network's is ()"),
            ({"policy.log_std": np.zeros((3, 3), np.float32)},
             "tensor policy.log_std has shape (3, 3), this network's is (3,)"),
            ({"policy.extra": np.zeros(3, np.float32)},
             "tensor policy.extra is not in this network"),
            ({"policy.value_net.bias": None},
             "its tensor file lacks tensor policy.value_net.bias")]:
        tensors = {k: v for k, v in {**intact, **change}.items() if v is not None}
        with pytest.raises(ckpt.CheckpointError) as err:
            ckpt.restore(build_model(config, tmp_path), doc, tensors, newest)
        assert str(err.value) == f"checkpoint {newest}: {line}"
    ckpt.restore(build_model(config, tmp_path), doc, intact, newest)  # the file as saved


def test_a_directory_under_a_checkpoints_name_is_refused_before_training(saved, tmp_path,
                                                                         capsys):
    from rallysim.cli import main

    run = _copy_run(saved, tmp_path)
    folder = run / "checkpoints"
    newest = folder / "step_000000001536.json"
    newest.unlink()
    newest.mkdir()  # resuming from 1024 would train to 1536, then fail to save there
    before = sorted((p.relative_to(run), p.stat().st_mtime_ns) for p in run.rglob("*"))
    assert main(_cli_args(run, {**TINY, "budget": 2048})) == 2
    err = capsys.readouterr().err
    assert err == (f"rallysim train: error: checkpoint {newest} is a directory, not a file: a "
                   "save cannot replace it; remove it or train again with --restart\n")
    assert sorted((p.relative_to(run), p.stat().st_mtime_ns) for p in run.rglob("*")) == before
    # a save that fails all the same leaves no temporary file behind
    with pytest.raises(IsADirectoryError):
        ckpt.atomic_write(newest, b"{}")
    assert sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp")) == []


def test_saving_a_step_again_writes_new_names_and_removes_the_old(saved, tmp_path):
    run = _copy_run(saved, tmp_path)
    folder = run / "checkpoints"
    path = folder / "step_000000001536.json"
    before = json.loads(path.read_text())["weights"]
    model = build_model(saved[1], tmp_path)
    model.num_timesteps = 1536
    with __import__("torch").no_grad():
        model.policy.log_std.fill_(0.25)  # other tensors than the saved ones
    ckpt.save_checkpoint(run, model, {"stage": "low", "network": saved[1].network(),
                                      "curve": {}})
    after = json.loads(path.read_text())["weights"]
    assert after != before and after.startswith("step_000000001536.")
    assert not (folder / before).exists()
    _assert_tidy(folder)
    _, tensors = ckpt.read_checkpoint(path)
    np.testing.assert_array_equal(tensors["policy.log_std"], np.full(3, 0.25, np.float32))
