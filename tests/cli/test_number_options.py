"""Every number option refuses NaN and infinity (issue 34: ``history -k nan`` flagged nothing).

Python's ``float()`` reads ``nan``, ``inf`` and ``1e999``; a NaN compares false with every
bound, so ``-k nan`` switched the outlier flags off and ``--timeout nan`` passed ``x > 0``.
"""

from __future__ import annotations

import importlib

import click
import pytest

from inertest.cli import _COMMANDS, main
from inertest.cli._common import REAL, FiniteFloat, FiniteFloatRange, parse_float_list


def _leaves(command: click.Command, path: str):
    if isinstance(command, click.Group):
        for name, sub in command.commands.items():
            yield from _leaves(sub, f"{path} {name}")
    else:
        yield path, command


def _all_commands():
    for name, (module, attr, _) in _COMMANDS.items():
        yield from _leaves(getattr(importlib.import_module(module), attr), name)


def test_every_number_option_of_every_command_is_finite():
    seen = 0
    for path, command in _all_commands():
        for p in command.params:
            if isinstance(p.type, click.types.FloatParamType):
                seen += 1
                assert isinstance(p.type, FiniteFloat | FiniteFloatRange), (
                    f"inertest {path} {p.opts[0]}: use type=REAL or FiniteFloatRange")
    assert seen >= 40


@pytest.mark.parametrize("text", ["nan", "NaN", "inf", "-inf", "1e999", "-Infinity"])
def test_nan_and_infinity_are_refused_with_the_fix(text):
    with pytest.raises(click.BadParameter, match="not a finite number; give a number"):
        REAL.convert(text, None, None)
    with pytest.raises(click.BadParameter, match="not a finite number"):
        FiniteFloatRange(min=0).convert(text, None, None)
    with pytest.raises(click.BadParameter, match="finite numbers"):
        parse_float_list(f"1,{text}", name="--x")


def test_numbers_and_ranges_still_read_as_before():
    assert REAL.convert("2.5", None, None) == 2.5 and REAL.convert(-3, None, None) == -3.0
    assert FiniteFloatRange(min=1.0).convert("3", None, None) == 3.0
    with pytest.raises(click.BadParameter, match="range"):
        FiniteFloatRange(min=1.0).convert("0.5", None, None)
    assert REAL.name == "float"  # the help still says FLOAT


@pytest.mark.parametrize("argv, option", [
    (["history", "FG-1", "-k", "nan"], "-k"), (["history", "FG-1", "-k", "inf"], "-k"),
    (["history", "FG-1", "-k", "0"], "-k"), (["allan", "x.npy", "--rate", "inf"], "--rate"),
    (["plan-check", "p.toml", "--spec", "x.npy", "--noise", "x.npy", "--tur", "nan"], "--tur"),
    (["batch", "p.toml", "--timeout", "nan"], "--timeout"),
])
def test_the_command_line_stops_before_any_work(argv, option, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "x.npy").write_bytes(b"")
    (tmp_path / "p.toml").write_text("")
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: Invalid value for '{option}'")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.toml", "x.npy"]
