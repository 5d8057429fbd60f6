"""The command line's help reads as plain text: every option of every command says what it
does and, where it has one, its default."""

from __future__ import annotations

import argparse

import pytest

from rallysim.cli import build_parser, main


def _commands() -> dict[str, argparse.ArgumentParser]:
    """The top-level parser and each subcommand's, by name."""
    parser = build_parser()
    (sub,) = (a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {"rallysim": parser, **sub.choices}


COMMANDS = _commands()


@pytest.mark.parametrize("name", COMMANDS)
def test_every_argument_has_help(name):
    parser = COMMANDS[name]
    missing = [a.option_strings or [a.dest] for a in parser._actions
               if not a.help or a.help == argparse.SUPPRESS]
    assert not missing, f"{name}: arguments without help: {missing}"


@pytest.mark.parametrize("name", COMMANDS)
def test_every_default_is_shown(name):
    """An option with a default says it: the formatter appends it, or its help says it in its
    own words (a default that depends on other options)."""
    parser = COMMANDS[name]
    formatter = parser._get_formatter()
    silent = []
    for action in parser._actions:
        if not action.option_strings or action.default in (None, False, [], argparse.SUPPRESS):
            continue
        if "default" not in formatter._expand_help(action):
            silent.append(action.option_strings)
    assert not silent, f"{name}: options whose help does not show their default: {silent}"


@pytest.mark.parametrize("name", COMMANDS)
def test_help_is_plain_text(name):
    text = COMMANDS[name].format_help()
    assert "``" not in text  # reStructuredText's literals


def test_top_level_help_lists_the_commands(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--help"])
    assert exit_.value.code == 0
    out = capsys.readouterr().out
    assert "``" not in out
    for name in ("demo", "train", "reproduce", "evaluate", "render", "play"):
        assert f"\n    {name}" in out


def test_play_opponent_help_names_the_shipped_champion():
    (opponent,) = (a for a in COMMANDS["play"]._actions if "--opponent" in a.option_strings)
    assert "default: simple_compete" in opponent.help
    assert "until the champion ships" not in opponent.help
