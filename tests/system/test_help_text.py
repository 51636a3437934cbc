"""Every flag's help says its default (or that it is required, or a switch) and, for a number, its range: walked
over every command's and subcommand's parser (mavbridge and each subcommand, sim-vehicle and its JSON backend,
mission and each subcommand, vessel and each subcommand), so that a flag added without them fails here."""

from __future__ import annotations

import argparse
import re
from collections.abc import Iterator

import pytest

import mavbridge.cli
import mission.cli
import sim_vehicle.cli
import sim_vehicle.json_backend.cli
import vessel.cli

PARSERS = {"mavbridge": mavbridge.cli.build_parser, "sim-vehicle": sim_vehicle.cli.build_parser,
           "sim-vehicle --json-backend": sim_vehicle.json_backend.cli.build_parser, "mission": mission.cli.build_parser,
           "vessel": vessel.cli.build_parser}
SWITCHES = (argparse._StoreTrueAction, argparse._StoreFalseAction, argparse._StoreConstAction, argparse._CountAction,
            argparse.BooleanOptionalAction, argparse._HelpAction, argparse._VersionAction)
DEFAULT = re.compile(r"default|required|\(none\)|optional|always|as given", re.IGNORECASE)
RANGE = re.compile(r"[\[(]\s*-?[\d.]+|[<>]=?\s*-?\d|≥|≤|\d\s*(\.\.|–|to)\s*\d|whole number|integer in")


NOT_YET: frozenset[str] = frozenset()  # still to write: empty now, and it only shrinks (fails on one now complete)


def _numeric(action: argparse.Action) -> bool:
    """A flag whose value is one number (int, float, or a type whose name or doc says so)."""
    kind = action.type
    if kind in (int, float):
        return True
    text = f"{getattr(kind, '__name__', '')} {getattr(kind, '__doc__', '') or ''}".lower()
    if kind is None or action.choices is not None or re.search(r"url|connection|,|pair|device|list", text):
        return False  # a string, a choice, or several values (their forms are checked as bad input)
    return bool(re.search(r"number|seconds|metres|port|speed-up|speedup|seed", text))


def options(parser: argparse.ArgumentParser, path: str) -> Iterator[tuple[str, argparse.Action]]:
    """(command path and flag, action) for every visible option of ``parser`` and its subcommands."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from options(sub, f"{path} {name}")
        elif action.option_strings and action.help != argparse.SUPPRESS:
            yield f"{path} {action.option_strings[-1]}", action


def problems(action: argparse.Action) -> list[str]:
    """What the flag's help leaves unsaid."""
    text = action.help or ""
    if isinstance(action, SWITCHES):
        return [] if text else ["no help"]
    found = []
    if not (DEFAULT.search(text) or action.required):
        found.append("no default")
    if _numeric(action) and not RANGE.search(text):
        found.append("no range")
    if action.choices is not None and not any(str(c) in text for c in action.choices) and action.metavar is None:
        found.append("choices not named")  # argparse shows {a,b} in the usage when there is no metavar
    return found


def _all() -> list[tuple[str, argparse.Action]]:
    return [item for name, build in PARSERS.items() for item in options(build(), name)]


def test_every_flag_says_its_default_and_range() -> None:
    """No flag's help is incomplete, but for those of :data:`NOT_YET` (each still incomplete: the list shrinks)."""
    bad = {name: problems(action) for name, action in _all() if problems(action)}
    new = {name: why for name, why in bad.items() if name not in NOT_YET}
    assert not new, "flags whose help is incomplete:\n" + "\n".join(f"  {k}: {', '.join(v)}" for k, v in new.items())
    done = sorted(set(NOT_YET) - set(bad))
    assert not done, f"complete now: take them off NOT_YET: {done}"


def test_the_defaults_the_companion_flags_name_are_the_config_s() -> None:
    """`mavbridge run`, `check` and `signing setup` say their link defaults without importing the companion's
    config (no pymavlink for --help): the numbers they say are CompanionConfig's."""
    from mavbridge.cli import args
    from mavbridge.companion.config import CompanionConfig

    config = CompanionConfig()
    assert (args.DEFAULT_CONNECT, args.DEFAULT_BAUD, args.DEFAULT_SYSID, args.DEFAULT_COMPID) == \
        (config.connect, config.baud, config.system_id, config.component_id)


@pytest.mark.parametrize("name", sorted(PARSERS))
def test_help_prints(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    """Every parser's --help prints and exits 0 (its format strings are valid)."""
    with pytest.raises(SystemExit) as done:
        PARSERS[name]().parse_args(["--help"])
    assert done.value.code == 0 and "usage:" in capsys.readouterr().out
