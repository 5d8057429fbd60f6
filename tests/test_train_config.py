"""The training configuration's layout (issue 16): top-level settings and the ``ppo``,
``warm_start`` and ``eval`` sections; ``--set SECTION.KEY=VALUE`` generated from the
dataclasses; the budget's unit per stage; the names from before the sections (``env``,
``decisions``, ``n_envs``, ...) and the ``--env``/``--decisions`` options still working, with a
deprecation notice; old records (a run's flat ``config.yaml``, the shipped policies' metadata)
read back."""

from __future__ import annotations

import json
import warnings
from dataclasses import fields
from pathlib import Path

import pytest

pytest.importorskip("yaml")

import yaml

from rallysim.cli import main
from rallysim.train import stages
from rallysim.train.config import (
    LEGACY_KEYS,
    TrainConfig,
    load_config,
    parse_overrides,
    setting_names,
)
from rallysim.train.sections import SECTIONS

PRETRAINED = Path(__file__).parents[1] / "src" / "rallysim" / "policies" / "pretrained"
OLD_RUN = Path(__file__).parent / "data" / "old_run_humanlike_low"


def _value(config: TrainConfig, dotted: str):
    value = config
    for part in dotted.split("."):
        value = getattr(value, part)
    return value


def test_settings_are_generated_from_the_dataclasses():
    sections = {f"{name}.{field.name}" for name, cls in SECTIONS.items()
                for field in fields(cls)}
    top = {field.name for field in fields(TrainConfig)} - set(SECTIONS)
    assert set(setting_names()) == sections | top
    # ppo: 18 with mean_bound, log_std_end; top level: 16 with returnable, ready
    assert len(setting_names()) == 18 + 10 + 3 + 13 + 16
    # every generated name is accepted by --set with the text of its current value
    base = load_config("high")
    for name in setting_names():
        value = _value(base, name)
        text = yaml.safe_dump(list(value) if isinstance(value, tuple) else value,
                              default_flow_style=True).strip().removesuffix("\n...")
        assert load_config("high", None, parse_overrides([f"{name}={text}"])) == base, name


def test_dotted_nested_and_yaml_forms_agree(tmp_path):
    dotted = load_config("low", None, parse_overrides(
        ["ppo.learning_rate=1e-3", "ppo.net_arch=[32, 32]", "eval.episodes=64",
         "warm_start.teacher=scripted", "warm_start.dagger=2", "budget=5e4"]))
    assert (dotted.ppo.learning_rate, dotted.ppo.net_arch, dotted.eval.episodes) == (
        1e-3, (32, 32), 64)
    assert (dotted.warm_start.teacher, dotted.warm_start.dagger, dotted.budget) == (
        "scripted", 2, 50_000)
    nested = load_config("low", None, {"ppo": {"learning_rate": 1e-3, "net_arch": [32, 32]},
                                       "eval": {"episodes": 64}, "budget": 50_000,
                                       "warm_start": {"teacher": "scripted", "dagger": 2}})
    path = tmp_path / "mine.yaml"
    path.write_text("budget: 5e4\nppo:\n  learning_rate: 1e-3\n  net_arch: [32, 32]\n"
                    "eval.episodes: 64\nwarm_start:\n  teacher: scripted\n  dagger: 2\n")
    assert dotted == nested == load_config("low", path)
    # a section in YAML updates only the fields it names: the stage's others stay
    assert (dotted.ppo.n_envs, dotted.eval.every) == (256, 250_000)


@pytest.mark.parametrize("key, hint", [("ppo.learning_rat", "ppo.learning_rate"),
                                       ("eval.episode", "eval.episodes"),
                                       ("learning_rat", "ppo.learning_rate")])
def test_unknown_setting_names_the_nearest(key, hint):
    with pytest.raises(ValueError, match=rf"unknown setting.*{key!r} \(did you mean "
                                         rf"{hint!r}\?\)"):
        load_config("low", None, {key: 1})


def test_budget_unit_per_stage_in_config_and_records(tmp_path):
    units = {name: load_config(name).budget_unit for name in stages.NAMES}
    assert units == {"low": "decisions", "high": "turns", "mono": "player-decisions",
                     "compete": "turns", "compete_mono": "decisions"}
    doc = load_config("mono").to_dict()
    assert list(doc)[3:5] == ["budget", "budget_unit"] and doc["budget_unit"] == (
        "player-decisions")
    # a written config.yaml reads back through --config; a unit of another stage is refused
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    assert load_config("mono", path) == load_config("mono")
    with pytest.raises(ValueError, match="budget_unit of the mono stage is 'player-decisions'"):
        load_config("mono", None, {"budget_unit": "turns"})


def test_every_old_flat_name_loads_with_a_deprecation_naming_the_new():
    assert len(LEGACY_KEYS) == 3 + 16 + 6 + 3
    base = load_config("low")
    for old, new in LEGACY_KEYS.items():
        value = _value(base, new)
        with pytest.warns(DeprecationWarning, match=f"'{old}' is deprecated: use '{new}'"):
            assert load_config("low", None, {old: value}) == base
    with pytest.warns(DeprecationWarning, match="TrainConfig.n_envs is deprecated"):
        assert base.n_envs == 256
    with pytest.warns(DeprecationWarning, match="TrainConfig.env is deprecated"):
        assert base.env == "simple"
    with pytest.raises(ValueError, match=r"ppo\.n_envs is set twice in the overrides"), \
            pytest.warns(DeprecationWarning):
        load_config("low", None, {"n_envs": 8, "ppo.n_envs": 16})


def test_old_env_key_in_yaml_selects_the_player_and_its_packaged_settings(tmp_path):
    path = tmp_path / "old.yaml"
    path.write_text("env: humanlike\ndecisions: 2048\nwarm_start_dagger: 2\n")
    with pytest.warns(DeprecationWarning) as caught:
        config = load_config("low", path)
    assert [str(w.message) for w in caught] == [
        "setting 'env' is deprecated: use 'player'",
        "setting 'decisions' is deprecated: use 'budget'",
        "setting 'warm_start_dagger' is deprecated: use 'warm_start.dagger'"]
    assert (config.player, config.budget, config.warm_start.dagger) == ("humanlike", 2048, 2)
    # low_humanlike.yaml applied under the user's file, as with player: humanlike
    assert (config.ppo.net_arch, config.warm_start.teacher) == ((256, 256), "scripted")
    assert config == load_config("low", None, {"player": "humanlike", "budget": 2048,
                                               "warm_start.dagger": 2})


def test_an_old_runs_flat_config_yaml_reads_back():
    with pytest.warns(DeprecationWarning):
        config = load_config("low", OLD_RUN / "config.yaml")
    assert (config.player, config.budget, config.seed, config.ppo.net_arch) == (
        "humanlike", 512, 3, (8, 8))
    assert (config.ppo.n_envs, config.eval.episodes, config.warm_start.teacher) == (
        16, 4, "none")


@pytest.mark.parametrize("name", ["simple_low", "simple_high", "simple_mono", "humanlike_low",
                                  "humanlike_high"])
def test_shipped_policies_metadata_reads_as_a_config(name):
    meta = json.loads((PRETRAINED / f"{name}.json").read_text())["metadata"]
    record = meta["config"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a record is read without deprecation warnings
        config = TrainConfig.from_dict(record, warn=False)
    player, stage = name.split("_")
    assert (config.player, config.stage, meta["stage"]) == (player, stage, stage)
    # a record is flat with the old names, or nested by section as runs write it today
    flat = {f"{key}.{k}" if isinstance(value, dict) else key: v
            for key, value in record.items()
            for k, v in (value.items() if isinstance(value, dict) else [(None, value)])}
    for old, value in flat.items():  # every recorded value lands under its new name
        new = LEGACY_KEYS.get(old, old)
        got = _value(config, new)
        assert (list(got) if isinstance(got, tuple) else got) == value, old


# --- the command line ------------------------------------------------------------------

@pytest.fixture
def trained(monkeypatch, tmp_path):
    """``rallysim train`` up to the training, which a stand-in records (config, out)."""
    import rallysim.train.runner

    calls: list[tuple[TrainConfig, Path]] = []

    def stand_in(config, out, **kwargs):
        calls.append((config, Path(out)))
        return {"steps": config.budget, "train_wall_s": 1.0, "steps_per_s": 1.0}

    monkeypatch.setattr(rallysim.train.runner, "train_stage", stand_in)
    monkeypatch.chdir(tmp_path)
    return calls


def test_env_option_is_a_deprecated_alias_of_player(trained, capsys):
    assert main(["train", "low", "--env", "humanlike", "--decisions", "4096"]) == 0
    captured = capsys.readouterr()
    assert captured.err.splitlines() == [
        "rallysim train: warning: --env is deprecated: use --player (same effect)",
        "rallysim train: warning: --decisions is deprecated: use --budget (same effect)"]
    assert captured.out.startswith("low: 4,096 decisions in 1 s")
    assert main(["train", "low", "--player", "humanlike", "--budget", "4096"]) == 0
    assert capsys.readouterr().err == ""
    (old, old_out), (new, new_out) = trained
    assert old == new and old.player == "humanlike" and old.budget == 4096
    assert old_out == new_out == Path("runs/low_humanlike_seed0")


def test_old_setting_names_on_the_command_line_say_their_new_names(trained, capsys):
    assert main(["train", "high", "--set", "n_envs=32", "eval_every=64",
                 "ppo.n_steps=16"]) == 0
    captured = capsys.readouterr()
    assert captured.err.splitlines() == [
        "rallysim train: warning: old setting names are deprecated (same effect): "
        "n_envs -> ppo.n_envs, eval_every -> eval.every"]
    config, _ = trained[0]
    assert (config.ppo.n_envs, config.eval.every, config.ppo.n_steps) == (32, 64, 16)
    assert "high: 60,000 turns in 1 s" in captured.out


def test_evaluate_env_option_is_a_deprecated_alias(monkeypatch, capsys):
    import rallysim.eval.humanlike_eval

    calls = []

    def stand_in(*args):
        calls.append(args)
        raise KeyboardInterrupt  # stop before printing results

    monkeypatch.setattr(rallysim.eval.humanlike_eval, "evaluate_humanlike_player", stand_in)
    for option in ("--env", "--player"):
        with pytest.raises(KeyboardInterrupt):
            main(["evaluate", option, "humanlike", "--episodes", "3"])
    err = capsys.readouterr().err.splitlines()
    assert err == ["rallysim evaluate: warning: --env is deprecated: use --player (same "
                   "effect)"]
    assert calls[0] == calls[1] and calls[0][2] == 3


def test_reproduce_takes_a_finished_run_only_with_its_own_settings(tmp_path):
    """A run in ``--out`` trained with other settings (another recipe) is refused, naming the
    settings; a record that predates a setting counts as having its default."""
    from rallysim.train.reproduce import check_same_settings

    run = tmp_path / "low_seed0"
    run.mkdir()
    asked = load_config("low", None, {"seed": 0})
    old = load_config("low", None, {"seed": 0, "returnable": 0.5}).to_dict()
    (run / "config.yaml").write_text(yaml.safe_dump(old))
    with pytest.raises(ValueError, match=r"low_seed0 was trained with other settings "
                                         r"\(returnable: 0.5 there, 0.0 here\)"):
        check_same_settings(run, asked)
    check_same_settings(run, load_config("low", None, {"seed": 0, "returnable": 0.5}))
    del old["returnable"], old["ready"]
    (run / "config.yaml").write_text(yaml.safe_dump(old))
    check_same_settings(run, asked)
    # the high stage's low level, named by a path written another way, and a backend's own
    # keys do not count
    high = load_config("high", None, {"seed": 0, "low_policy": "out/runs/low_seed0/policy"})
    doc = {**high.to_dict(), "low_policy": "/abs/out/runs/low_seed0/policy", "backend": "sb3"}
    (run / "config.yaml").write_text(yaml.safe_dump(doc))
    check_same_settings(run, high)
    old["ppo"]["n_epochs"] = 5
    (run / "config.yaml").write_text(yaml.safe_dump(old))
    with pytest.raises(ValueError, match=r"ppo.n_epochs: 5 there, 10 here.*remove that run and "
                                         r"the seed's later stages"):
        check_same_settings(run, asked)


def test_the_reward_options_belong_to_the_simple_low_stage():
    with pytest.raises(ValueError, match=r"returnable=0\.5: the SIMPLE low stage's reward "
                                         r"options, not the .* high stage's"):
        load_config("high", None, {"returnable": 0.5})
    with pytest.raises(ValueError, match=r"ready=1\.0: the SIMPLE low stage's"):
        load_config("low", None, {"player": "humanlike", "ready": 1.0})
    assert load_config("low", None, {"ready": 1.0}).ready == 1.0
