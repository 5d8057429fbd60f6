"""Every user error of the command line is one line on stderr and exit status 2, found before
any long work (issue 17): bad options and values, unusable paths for ``--out``, ``--json`` and
``--config`` (and the files a command writes inside ``--out``), and bad training settings.

The cases are importable for a fuzz suite: ``cli_bad_inputs(root)`` builds the files the path
cases need under ``root`` and yields each bad argv list; ``bad_input_templates()`` gives the
same cases with placeholders (``<file>``, ``<dir>``, ...) that ``fill`` replaces.
"""

from __future__ import annotations

import math
import os
import stat
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest

from rallysim import cli
from rallysim.cli import main, path_problem
from rallysim.train import config as train_config
from rallysim.train.config import TrainConfig, load_config, parse_overrides
from rallysim.train.sections import EvalSettings, PPOSettings

LONG_NAME = "x" * 300  # over NAME_MAX (255 bytes) of every common Linux file system

# what the path placeholders stand for (made by ``make_tree``)
CONFIG_FILES = {
    "bad_yaml": "n_envs: [\n",
    "list_yaml": "- 1\n- 2\n",
    "scalar_yaml": "42\n",
    "unknown_yaml": "lr: 1.0\n",
    "stage_yaml": "stage: nope\n",
    "gamma_yaml": "ppo:\n  gamma: 5\n",
    "nan_yaml": "learning_rate: .nan\n",  # an old flat name: still checked
    "section_yaml": "ppo: 3\n",
    "nullkey_yaml": "null: 1\n1: 3\n",  # keys that do not sort with the field names
}

# (what a bad path must be for, the option's commands) -> ids and paths of bad values
PATH_OPTIONS: list[tuple[str, list[str]]] = [
    ("dir", ["train", "low", "--out"]),
    ("dir", ["train", "high", "--out"]),
    ("dir", ["train", "mono", "--out"]),
    ("dir", ["reproduce", "--out"]),
    ("dir", ["reproduce", "--budget", "smoke", "--out"]),
    ("dir", ["render", "--out"]),
    ("dir", ["render", "--env", "low", "--out"]),
    ("file", ["evaluate", "--json"]),
    ("file", ["evaluate", "--env", "humanlike", "--json"]),
    ("file", ["evaluate", "--rallies", "1", "--seeds", "1", "--json"]),
    ("input", ["train", "low", "--config"]),
    ("input", ["train", "high", "--config"]),
    ("input", ["train", "mono", "--config"]),
]
BAD_PATHS: dict[str, dict[str, str]] = {
    "dir": {
        "is-a-file": "<file>",
        "under-a-file": "<file>/sub",
        "deep-under-a-file": "<file>/a/b",
        "unwritable": "<unwritable>",
        "in-unwritable": "<unwritable>/out",
        "empty": "",
        "nul": "a\0b",
        "name-too-long": f"<dir>/{LONG_NAME}",
    },
    "file": {
        "is-a-dir": "<dir>",
        "dir-slash": "<dir>/",
        "new-dir-slash": "<missing>/new/",
        "under-a-file": "<file>/x.json",
        "deep-under-a-file": "<file>/a/x.json",
        "in-unwritable": "<unwritable>/x.json",
        "unwritable-file": "<unwritable_file>",
        "empty": "",
        "nul": "a\0b",
        "name-too-long": f"<dir>/{LONG_NAME}.json",
    },
    "input": {
        "is-a-dir": "<dir>",
        "missing-file": "<dir>/none.yaml",
        "missing-parent": "<missing>/c.yaml",
        "under-a-file": "<file>/c.yaml",
        "unreadable": "<unreadable>",
        "empty": "",
        "nul": "a\0b",
        "name-too-long": f"<dir>/{LONG_NAME}.yaml",
        "binary": "<binary_yaml>",
        **{name.removesuffix("_yaml"): f"<{name}>" for name in CONFIG_FILES},
    },
}
# what the one line must name, per config file (the others name the option)
CONFIG_FILE_WORDS = {"gamma_yaml": "ppo.gamma", "nan_yaml": "ppo.learning_rate",
                     "unknown_yaml": "unknown setting", "nullkey_yaml": "unknown setting",
                     "stage_yaml": "stage", "section_yaml": "section"}

# --set KEY=VALUE that no stage accepts (the line names the key)
BAD_SETTINGS = [
    "ppo.n_envs=abc", "ppo.n_envs=0", "ppo.n_envs=-4", "ppo.n_envs=1.5", "ppo.n_envs=true",
    "ppo.n_envs=.nan", "ppo.n_envs=[64]", "ppo.n_steps=0", "ppo.batch_size=0",
    "ppo.batch_size=-1", "ppo.n_epochs=0", "budget=-1", "budget=0", "budget=abc",
    "budget=1e400", "seed=-1", "seed=2147483648", "seed=1.5", "eval.seed=-1",
    "ppo.learning_rate=0", "ppo.learning_rate=-0.001", "ppo.learning_rate=.inf",
    "ppo.learning_rate=.nan", "ppo.learning_rate=nan", "ppo.learning_rate=abc",
    "ppo.learning_rate=true", "ppo.gamma=5", "ppo.gamma=-0.1", "ppo.gamma=1.0001",
    "ppo.gamma=.nan", "ppo.gae_lambda=1.5", "ppo.gae_lambda=-1", "ppo.clip_range=0",
    "ppo.clip_range=-0.2", "ppo.clip_range=.nan", "ppo.ent_coef=-0.01", "ppo.ent_coef=.inf",
    "ppo.vf_coef=-1", "ppo.max_grad_norm=0", "ppo.target_kl=0", "ppo.target_kl=-0.1",
    "ppo.target_kl=.nan", "ppo.target_kl=abc", "ppo.net_arch=[0]", "ppo.net_arch=[64,0]",
    "ppo.net_arch=[64,-1]", "ppo.net_arch=abc", "ppo.net_arch=64", "ppo.net_arch=[1.5]",
    "ppo.net_arch=[true]", "ppo.net_arch={a: 1}", "ppo.activation=sigmoid",
    "ppo.activation=", "ppo.log_std_init=.nan", "ppo.log_std_init=-.inf", "torch_threads=0",
    "eval.every=-1", "eval.episodes=0", "checkpoint_every=0", "low_policy=", "low_policy=5",
    "incoming=volley", "goals=anywhere", "keep_bodies=maybe", "returnable=-0.5",
    "returnable=.nan", "returnable=high", "ready=-1", "ready=no", "ppo.anneal_lr=2",
    "warm_start.teacher=teacher",
    "warm_start.decisions=0", "warm_start.epochs=0", "warm_start.log_std=.nan",
    "warm_start.dagger=-1", "warm_start.batch_size=0", "warm_start.lr=0",
    "warm_start.lr_decay=3", "shuttle=feather", "player=3d", "stage=nope", "foo=1",
    "ppo.foo=1", "foo.n_envs=1", "budget_unit=weeks", "ppo=3", "n_envs", "=3",
    "ppo.net_arch=[1,", "ppo.gamma=[1",
]
# the names from before the sections, with a bad value: the line names the setting's new name
LEGACY_BAD_SETTINGS = [("n_envs=0", "ppo.n_envs"), ("decisions=abc", "budget"),
                       ("env=3d", "player"), ("warm_start=teacher", "warm_start.teacher"),
                       ("warm_start_dagger=-1", "warm_start.dagger"),
                       ("eval_episodes=0", "eval.episodes"),
                       ("net_arch=[64,0]", "ppo.net_arch"),
                       ("n_envs=8 ppo.n_envs=16", "twice")]
# settings bad for one stage only
STAGE_SETTINGS = [("mono", "ppo.n_envs=3", "ppo.n_envs"),
                  ("high", "warm_start.teacher=scripted", "warm_start"),
                  ("mono", "warm_start.teacher=scripted", "warm_start"),
                  ("low", "goal_sweep=8", "goal_sweep")]

# argparse-level errors: (argv, a word the line must hold)
OPTION_ERRORS: list[tuple[list[str], str]] = [
    *[(["render", "--size", size], "--size") for size in (
        "100000x100000", "4097x360", "640x4097", "10x10", "15x360", "0x0", "-640x360", "abc",
        "640x", "x360", "640x360x2", "")],
    *[(["render", "--gif-every", v], "--gif-every") for v in ("-1", "0", "abc", "1.5", "101",
                                                               "100000")],
    *[(["play", "--seconds", v], "--seconds") for v in ("-1", "0", "nan", "inf", "abc")],
    *[([cmd, "--high", v], "fixed") for cmd in ("render", "evaluate")
      for v in ("fixed:nan", "fixed:inf", "fixed:abc")],
    *[(["render", opt, v], opt) for opt in ("--stills", "--episodes") for v in ("0", "-1")],
    (["render", "--env", "bogus"], "--env"), (["render", "--camera", "top"], "--camera"),
    (["render", "--mode", "solo"], "--mode"),
    *[([cmd, "--seed", v], "--seed") for cmd in ("demo", "render", "play", "train")
      for v in ("-1", "abc", "2147483648")],
    (["demo", "--episodes", "0"], "--episodes"), (["demo", "--envs", "0"], "--envs"),
    (["demo", "--envs", "-1"], "--envs"), (["demo", "--shuttle", "bogus"], "--shuttle"),
    (["demo", "--bogus-option"], "unrecognized"), (["demo", "extra"], "unrecognized"),
    (["evaluate", "--rallies", "0"], "--rallies"), (["evaluate", "--seeds", "0"], "--seeds"),
    (["evaluate", "--episodes", "0"], "--episodes"), (["evaluate", "--cap", "0"], "--cap"),
    (["evaluate", "--cap", "100001"], "--cap"), (["evaluate", "--env", "bogus"], "--env"),
    (["evaluate", "--player", "bogus"], "--player"),
    (["evaluate", "--env", "humanlike", "--cap", "10"], "--cap"),
    (["evaluate", "--player", "humanlike", "--cap", "10"], "--cap"),
    (["evaluate", "--mode", "competitive", "--players", "random"], "--players"),
    (["evaluate", "--mode", "competitive", "--players", "random", "bogus"], "bogus"),
    (["evaluate", "--players", "random", "scripted"], "--mode competitive"),
    (["evaluate", "--mode", "competitive", "--players", "hrl", "mono", "--games", "0"],
     "--games"),
    (["evaluate", "--mode", "competitive", "--players", "hrl", "mono", "--cap", "10"], "--cap"),
    (["reproduce", "--cap", "0"], "--cap"), (["reproduce", "--cap", "100001"], "--cap"),
    (["reproduce", "--seeds", "0"], "--seeds"), (["reproduce", "--workers", "0"], "--workers"),
    (["reproduce", "--budget", "huge"], "--budget"),
    (["train"], "stage"), (["train", "bogus"], "stage"), (["train", "low", "--backend", "x"],
                                                        "--backend"),
    (["train", "low", "--env-runners", "-1"], "--env-runners"),
    (["train", "low", "--address", "auto"], "--backend rllib"),
    (["train", "low", "--env-runners", "2"], "--backend rllib"),
    (["train", "low", "--decisions", "abc"], "--decisions"),
    (["train", "low", "--decisions", "-5"], "budget (decisions)"),
    (["train", "low", "--decisions", "0"], "budget (decisions)"),
    (["train", "low", "--budget", "abc"], "--budget"),
    (["train", "high", "--budget", "0"], "budget (turns)"),
    (["train", "mono", "--budget", "-1"], "budget (player-decisions)"),
    (["train", "low", "--shuttle", "x"], "--shuttle"), (["train", "low", "--env", "x"], "--env"),
    (["train", "low", "--player", "x"], "--player"),
    (["reproduce", "--player", "humanlike", "--budget", "rl"], "no budget 'rl'"),
    (["play", "--human", "2"], "--human"), (["play", "--mode", "x"], "--mode"),
    ([], "command"), (["bogus"], "bogus"), (["--bogus"], "command"),
    (["--bogus", "demo"], "unrecognized"),
    (["demo", "--policy", "no/such/policy"], "policy"),
    (["render", "--policy", "no/such/policy"], "policy"),
    (["render", "--high", "no/such/policy"], "policy"),
]


def bad_input_templates() -> list[tuple[str, list[str], str]]:
    """Every bad command line as (id, argv with placeholders, a word its error line holds)."""
    cases: list[tuple[str, list[str], str]] = []
    for want, prefix in PATH_OPTIONS:
        option = prefix[-1]
        for name, path in BAD_PATHS[want].items():
            placeholder = path.strip("<>")
            word = CONFIG_FILE_WORDS.get(placeholder, "config file" if placeholder in
                                         CONFIG_FILES or name == "binary" else option)
            cases.append((f"{' '.join(prefix)}:{name}", [*prefix, path], word))
    for stage in ("low", "high", "mono"):
        for item in BAD_SETTINGS:
            key = item.partition("=")[0]
            cases.append((f"train {stage} --set {item}", ["train", stage, "--set", item],
                          key or "--set"))
    for stage in ("low", "high", "mono"):
        for items, word in LEGACY_BAD_SETTINGS:
            cases.append((f"train {stage} --set {items}", ["train", stage, "--set",
                                                            *items.split()], word))
    for stage, item, word in STAGE_SETTINGS:
        cases.append((f"train {stage} --set {item}", ["train", stage, "--set", item], word))
    # files a command writes inside a usable --out, where a folder stands in the way
    cases += [("render --out:mp4-is-a-dir", ["render", "--out", "<clash>"], "rally_scripted.mp4"),
              ("render low --out:strip-is-a-dir", ["render", "--env", "low", "--out", "<clash>"],
               "low_scripted_strip.png"),
              ("reproduce --out:results-is-a-dir", ["reproduce", "--out", "<clash>"],
               "results.json")]
    cases += [(" ".join(argv) or "(nothing)", argv, word) for argv, word in OPTION_ERRORS]
    return cases


def _writes_blocked(folder: Path) -> bool:
    # as root, a read-only mode does not stop a write: try it rather than trust the mode
    probe = folder / "probe"
    try:
        probe.write_text("x")
    except OSError:
        return True
    probe.unlink()
    return False


def make_tree(root: Path) -> dict[str, str]:
    """Make the files the placeholders name under ``root``; returns placeholder -> path."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "file").write_text("a regular file\n")
    (root / "dir").mkdir(exist_ok=True)
    for name, text in CONFIG_FILES.items():
        (root / f"{name}.yaml").write_text(text)
    (root / "binary.yaml").write_bytes(b"\xff\xfe\x00\x81 not utf-8")
    for blocker in ("rally_scripted.mp4", "low_scripted_strip.png", "results.json"):
        (root / "clash" / blocker).mkdir(parents=True, exist_ok=True)
    locked = root / "locked"
    locked.mkdir(exist_ok=True)
    (locked / "readonly.json").write_text("{}")
    (locked / "secret.yaml").write_text("n_envs: 8\n")
    (locked / "secret.yaml").chmod(0)
    (locked / "readonly.json").chmod(stat.S_IRUSR)
    locked.chmod(stat.S_IRUSR | stat.S_IXUSR)
    tree = {"file": root / "file", "dir": root / "dir", "missing": root / "missing",
            "clash": root / "clash", "binary_yaml": root / "binary.yaml",
            **{name: root / f"{name}.yaml" for name in CONFIG_FILES}}
    if _writes_blocked(locked):
        tree.update(unwritable=locked, unwritable_file=locked / "readonly.json",
                    unreadable=locked / "secret.yaml")
    else:  # running as root: a folder that refuses files, or a path through a regular file
        proc = Path("/proc")
        unwritable = proc if proc.is_dir() and _writes_blocked(proc) else root / "file" / "sub"
        tree.update(unwritable=unwritable, unwritable_file=unwritable / "x.json",
                    unreadable=root / "file" / "secret.yaml")
    return {key: str(path) for key, path in tree.items()}


def unlock_tree(root: Path) -> None:
    """Undo ``make_tree``'s permissions so that ``root`` can be deleted."""
    locked = root / "locked"
    if locked.exists():
        locked.chmod(stat.S_IRWXU)
        for child in locked.iterdir():
            child.chmod(stat.S_IRUSR | stat.S_IWUSR)


def fill(argv: list[str], tree: dict[str, str]) -> list[str]:
    out = []
    for arg in argv:
        for key, path in tree.items():
            arg = arg.replace(f"<{key}>", path)
        out.append(arg)
    return out


def cli_bad_inputs(root: Path) -> Iterator[list[str]]:
    """Every bad command line, its paths made under ``root`` (call ``unlock_tree(root)``
    after use)."""
    tree = make_tree(root)
    for _, argv, _ in bad_input_templates():
        yield fill(argv, tree)


class LongWork(BaseException):
    """Raised by the stand-ins of the long commands: main must never get that far. A
    BaseException, so that main's handler of user errors cannot swallow it."""


@pytest.fixture
def no_long_work(monkeypatch, tmp_path):
    """Replace every long piece of work with a stand-in that records its call and raises
    LongWork; run in an empty folder so default outputs (runs/, results/) land there."""
    import rallysim.eval.compare
    import rallysim.eval.humanlike_eval
    import rallysim.eval.low_eval
    import rallysim.render.play
    import rallysim.render.record
    import rallysim.train.reproduce
    import rallysim.train.runner

    calls: list[str] = []

    def stand_in(name):
        def run(*args, **kwargs):
            calls.append(name)
            raise LongWork(name)

        return run

    targets = [(rallysim.train.runner, "train_stage"), (rallysim.train.reproduce, "run_reproduce"),
               (rallysim.eval.compare, "evaluate_methods"),
               (rallysim.eval.humanlike_eval, "evaluate_humanlike_player"),
               (rallysim.eval.low_eval, "evaluate_return"),
               (rallysim.render.record, "record_low_level"),
               (rallysim.render.record, "record_rally"), (rallysim.render.play, "play")]
    for module, name in targets:
        monkeypatch.setattr(module, name, stand_in(name))
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("RALLYSIM_TRACEBACK", raising=False)
    return calls


@pytest.fixture(scope="module")
def tree(tmp_path_factory) -> Iterator[dict[str, str]]:
    root = tmp_path_factory.mktemp("cli_paths")
    yield make_tree(root)
    unlock_tree(root)


TEMPLATES = bad_input_templates()


def test_enough_cases_and_unique_ids():
    ids = [case_id for case_id, _, _ in TEMPLATES]
    assert len(ids) == len(set(ids))
    assert len(ids) >= 300


@pytest.mark.parametrize("argv, word", [(argv, word) for _, argv, word in TEMPLATES],
                         ids=[case_id for case_id, _, _ in TEMPLATES])
def test_user_error_is_one_line_and_exit_2(argv, word, tree, no_long_work, capsys):
    code = main(fill(argv, tree))
    out, err = capsys.readouterr()
    assert code == 2
    assert no_long_work == []
    assert out == ""  # nothing started: not even a "rendering ..." line
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and err.endswith("\n"), err
    assert lines[0].startswith("rallysim") and ": error: " in lines[0]
    assert word in lines[0], lines[0]


def test_cli_bad_inputs_is_reusable(tmp_path, no_long_work, capsys):
    argvs = list(cli_bad_inputs(tmp_path / "fuzz"))
    try:
        assert len(argvs) == len(TEMPLATES)
        assert not any("<" in arg for argv in argvs for arg in argv)  # every placeholder filled
        for argv in argvs[::25]:  # a sample: the full set runs above
            assert main(argv) == 2
    finally:
        unlock_tree(tmp_path / "fuzz")
    assert no_long_work == []
    assert len(capsys.readouterr().err.splitlines()) == len(argvs[::25])


def test_default_run_folder_is_checked_before_training(no_long_work, tmp_path, capsys):
    (tmp_path / "runs").write_text("a file where the default run folder's parent goes")
    assert main(["train", "low", "--seed", "3"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "runs/low_seed3" in err and "not a directory" in err
    assert no_long_work == []


def test_good_paths_reach_the_work(no_long_work, tmp_path, tree):
    """The checks refuse only what cannot work: new nested folders and files, and a readable
    config, get as far as the long work (the stand-in)."""
    runs = [["evaluate", "--json", str(tmp_path / "new" / "deeper" / "all.json")],
            ["evaluate", "--json", str(Path(tree["dir"]) / "existing.json")],
            ["train", "low", "--out", str(tmp_path / "a" / "b"), "--config",
             str(tmp_path / "mine.yaml"), "--set", "ppo.learning_rate=3e-4", "budget=1e4"],
            ["reproduce", "--out", str(tmp_path / "r")],
            ["render", "--out", str(tmp_path / "v" / "w")]]
    (tmp_path / "mine.yaml").write_text("ppo:\n  n_envs: 32\n")
    (Path(tree["dir"]) / "existing.json").write_text("{}")
    for argv in runs:
        with pytest.raises(LongWork):
            main(argv)
    assert no_long_work == ["evaluate_methods", "evaluate_methods", "train_stage",
                            "run_reproduce", "record_rally"]
    assert not (tmp_path / "new").exists()  # checked, not created, before the evaluation


def test_traceback_on_request(monkeypatch, no_long_work):
    monkeypatch.setenv("RALLYSIM_TRACEBACK", "1")
    with pytest.raises(ValueError, match=r"ppo\.gamma must be in"):
        main(["train", "low", "--set", "ppo.gamma=5"])


@pytest.mark.slow
@pytest.mark.skipif(not (hasattr(os, "mkfifo") and Path("/dev/zero").exists()),
                    reason="needs FIFOs, symbolic links and /dev/zero")
def test_policy_loader_says_what_a_path_that_is_not_a_file_is(tmp_path, no_long_work, capsys):
    from rallysim.policies.mlp import load_policy
    from rallysim.policies.registry import PRETRAINED

    said = {"dir": "is a directory, not a file", "fifo": "is a FIFO (named pipe), not a file",
            "loop": "is a loop of symbolic links",
            "zero": "is a symbolic link to a character device (/dev/zero), not a file"}
    for name in said:  # a good tensor file beside each: the JSON half is what is wrong
        (tmp_path / f"{name}.safetensors").write_bytes(
            (PRETRAINED / "simple_low.safetensors").read_bytes())
    (tmp_path / "dir.json").mkdir()
    os.mkfifo(tmp_path / "fifo.json")
    (tmp_path / "loop.json").symlink_to("loop.json")
    (tmp_path / "zero.json").symlink_to("/dev/zero")
    for name, what in said.items():
        line = f"policy file {tmp_path / name}.json {what}"
        with pytest.raises(ValueError) as err:
            load_policy(tmp_path / name)
        assert str(err.value) == line
        assert main(["demo", "--policy", str(tmp_path / name)]) == 2
        assert capsys.readouterr().err == f"rallysim demo: error: {line}\n"
    with pytest.raises(FileNotFoundError, match=r"none\.safetensors does not exist$"):
        load_policy(tmp_path / "none")
    # the command line's own check of an input file says the same (a stream stays readable)
    for name in ("dir", "loop"):
        path = str(tmp_path / f"{name}.json")
        assert path_problem(path, "input") == f"{path!r} {said[name]}"
    assert path_problem(str(tmp_path / "fifo.json"), "input") is None
    assert no_long_work == []


def test_a_bare_prefix_whose_json_is_not_a_file_is_named_as_such(tmp_path, monkeypatch):
    """A relative prefix with no separator ("dir") is a policy path when its JSON is there in
    any form: the loader then says what that is, not "unknown policy" or "unknown player"."""
    from rallysim.eval.agents import agent
    from rallysim.policies.registry import PRETRAINED, resolve

    monkeypatch.chdir(tmp_path)
    (tmp_path / "dir.safetensors").write_bytes(
        (PRETRAINED / "simple_high.safetensors").read_bytes())
    (tmp_path / "dir.json").mkdir()
    for load in (lambda: resolve("dir", "high"), lambda: agent("dir")):
        with pytest.raises(ValueError, match=r"dir\.json is a directory, not a file"):
            load()


@pytest.mark.parametrize("text, want, problem", [
    ("", "dir", "empty"), ("a\0b", "file", "NUL"), ("x/", "file", "ends with '/'"),
    ("<file>", "dir", "not a directory"), ("<file>/a", "file", "not a directory"),
    ("<dir>", "file", "directory, not a file"), ("<dir>", "input", "directory, not a file"),
    ("<missing>/c.yaml", "input", "does not exist"), (f"<dir>/{LONG_NAME}", "dir", "too long"),
])
def test_path_problem_names_the_problem(text, want, problem, tree):
    assert problem in path_problem(fill([text], tree)[0], want)


@pytest.mark.parametrize("text, want", [("<dir>", "dir"), ("<dir>/new/deeper", "dir"),
                                        ("<dir>/new/x.json", "file"), ("<file>", "file"),
                                        ("<gamma_yaml>", "input")])
def test_path_problem_passes_usable_paths(text, want, tree):
    assert path_problem(fill([text], tree)[0], want) is None
    assert not (Path(tree["dir"]) / "new").exists()


def test_config_validated_at_construction_and_replace():
    with pytest.raises(ValueError, match=r"^ppo.gamma must be in \[0, 1\], got 5$"):
        PPOSettings(gamma=5)
    with pytest.raises(ValueError, match=r"^ppo.gamma must be in \[0, 1\], got 5$"):
        TrainConfig(ppo={"gamma": 5})  # a section given as a mapping is checked the same
    with pytest.raises(ValueError, match=r"^ppo.net_arch layer widths must be >= 1, got "
                                         r"\[64, 0\]$"):
        replace(TrainConfig().ppo, net_arch=(64, 0))
    with pytest.raises(ValueError, match=r"^ppo.learning_rate must be finite, got nan$"):
        PPOSettings(learning_rate=math.nan)
    with pytest.raises(ValueError, match=r"^ppo.n_envs must be an integer, got True$"):
        PPOSettings(n_envs=True)
    with pytest.raises(ValueError, match=r"^ppo.net_arch must be a list of integer layer "
                                         r"widths, got \[64, 1\.5\]$"):
        PPOSettings(net_arch=(64, 1.5))
    with pytest.raises(ValueError, match=r"^eval.episodes must be >= 1, got 0$"):
        replace(TrainConfig(), eval=EvalSettings(episodes=0))
    with pytest.raises(ValueError, match=r"^budget \(turns\) must be >= 1, got 0$"):
        TrainConfig(stage="high", budget=0)
    with pytest.raises(ValueError, match=r"^ppo must be a mapping of its settings, got 3$"):
        TrainConfig(ppo=3)
    # a config rebuilt from its own dict (sections as mappings, net_arch as a list) equals the
    # original, through from_dict or the constructor
    original = load_config("high")
    assert TrainConfig.from_dict(original.to_dict()) == original
    fields_only = {k: v for k, v in original.to_dict().items() if k != "budget_unit"}
    assert TrainConfig(**fields_only) == original
    # the edges of each range are accepted
    edge = TrainConfig(seed=train_config.SEED_MAX, ppo=PPOSettings(
        gamma=0, gae_lambda=1, target_kl=None, ent_coef=0, vf_coef=0, net_arch=()),
        eval=EvalSettings(every=0))
    assert (edge.ppo.gamma, edge.ppo.gae_lambda, edge.seed, edge.ppo.net_arch) == (
        0, 1, 2**31 - 1, ())


def test_settings_text_is_read_as_the_field_type():
    # PyYAML reads 3e-4 and 1e6 (no dot) as strings: they are what a user means
    c = load_config("low", None, parse_overrides(["ppo.learning_rate=3e-4", "budget=1e6",
                                                  "ppo.net_arch=[32.0, 16]",
                                                  "ppo.target_kl=0.02"]))
    assert (c.ppo.learning_rate, c.budget, c.ppo.net_arch, c.ppo.target_kl) == (
        3e-4, 1_000_000, (32, 16), 0.02)
    assert type(c.budget) is int and all(type(w) is int for w in c.ppo.net_arch)


def test_copies_of_bounds_match_their_source():
    from rallysim.core.tasks.simple_return import GOALS, INCOMING, REWARD_OPTIONS

    assert train_config.INCOMING == INCOMING and train_config.GOALS == GOALS
    assert train_config.REWARD_OPTIONS == REWARD_OPTIONS
    assert cli.SEED_MAX == train_config.SEED_MAX


def test_every_packaged_config_is_valid():
    for stage in ("low", "high", "mono"):
        for player in ("simple", "humanlike"):
            config = load_config(stage, None, {"player": player})
            assert (config.stage, config.player) == (stage, player)


def test_unlock_tree_leaves_a_deletable_tree(tmp_path):
    make_tree(tmp_path / "t")
    unlock_tree(tmp_path / "t")
    assert os.access(tmp_path / "t" / "locked", os.W_OK)
