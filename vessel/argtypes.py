"""argparse types and checks shared by every command line: positive finite quantities (argparse names the flag in
front), output files checked before any work, and file errors that name the flag they came from."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NoReturn

from vessel.config import ConfigError


def positive_quantity(what: str, unit: str) -> Callable[[str], float]:
    """An argparse type for a finite number > 0 of ``what`` (e.g. "a distance in metres"), unit ``unit``."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what} > 0, got {text!r}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"{text!r} is outside the allowed range: finite and > 0 {unit}")
        return value

    parse.__doc__ = f"{what} > 0 {unit}, finite (argparse type)"
    return parse


positive_metres = positive_quantity("a distance in metres", "m")
positive_seconds = positive_quantity("seconds", "s")


SEED_MAX = 2**32 - 1  # the simulator's and the irregular seas' seeds are 32-bit


def seed_number(text: str) -> int:
    """A random seed: a whole number in [0, 2^32 − 1] (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seed must be an integer in [0, {SEED_MAX}], got {text!r}") from None
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"seed must be an integer in [0, {SEED_MAX}], got {value}")
    return value


@contextmanager
def naming(flag: str) -> Iterator[None]:
    """Let a ConfigError raised inside (a file's, say ``otter.yaml: hull_mass: …``) start with ``flag``, so that
    the user sees which flag gave the file; one that already starts with a flag (``--sea: …``) is left alone."""
    try:
        yield
    except ConfigError as exc:
        text = str(exc)
        if text.startswith("--"):
            raise
        raise ConfigError(f"{flag}: {text}") from None


def plot_formats() -> frozenset[str]:
    """File name extensions matplotlib can write (".png", ".pdf", …); imports matplotlib, so only when asked."""
    from matplotlib.backend_bases import FigureCanvasBase

    return frozenset(f".{name}" for name in FigureCanvasBase.get_supported_filetypes())


def check_output_file(path: str | Path, flag: str, suffixes: Collection[str] | None = None) -> None:
    """Refuse, before any work, an output file that cannot be written: a folder, a name under a folder that
    does not exist (nothing is created on the way) or under a file, or (given ``suffixes``) an extension not
    in them. A one-line ConfigError naming ``flag``."""
    target = Path(path)
    if target.is_dir():
        raise ConfigError(f"{flag}: {path} is a folder; give a file name")
    parent = target.parent
    if not parent.is_dir():
        why = "is a file, not a folder" if parent.exists() else "does not exist (it is not created)"
        raise ConfigError(f"{flag}: {path}: the folder {parent} {why}")
    if suffixes is not None and target.suffix.lower() not in suffixes:
        raise ConfigError(f"{flag}: {path}: unsupported file type {target.suffix or '(none)'}; allowed "
                          f"{', '.join(sorted(suffixes))}")


def check_output_folder(path: str | Path, flag: str) -> None:
    """Refuse an output folder that cannot be made: an existing file, or a name under a file. One-line
    ConfigError naming ``flag``; a folder that does not exist yet is fine (it is made when the run starts)."""
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise ConfigError(f"{flag}: {path} is a file, not a folder")
    for parent in target.parents:
        if parent.exists():
            if not parent.is_dir():
                raise ConfigError(f"{flag}: {path}: {parent} is a file, not a folder")
            return


DISTRIBUTION = "otter-rollaware"  # the installed distribution whose version every console script reports


def version_line(prog: str) -> str:
    """'PROG VERSION' from the installed package's metadata (never a literal that drifts from pyproject.toml)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return f"{prog} {version(DISTRIBUTION)}"
    except PackageNotFoundError:  # run from a source tree that was never installed
        return f"{prog} (version unknown: {DISTRIBUTION} is not installed)"


class OneLineParser(argparse.ArgumentParser):
    """The parser every console script uses, so that they all behave alike: an error is one line on stderr and exit
    code 2 (no usage dump); a command given without its subcommand prints its usage and the list of subcommands
    (exit 2), not only "the following arguments are required"; ``--version`` on the top-level parser
    (``add_version``)."""

    def error(self, message: str) -> NoReturn:  # type: ignore[override]
        """Print 'prog: error: message' and exit 2; a missing subcommand: the usage and the subcommands."""
        commands = [a for a in self._actions if isinstance(a, argparse._SubParsersAction)]
        if commands and message.startswith(f"the following arguments are required: {commands[0].dest}"):
            self.exit(2, self.format_help())
        self.exit(2, f"{self.prog}: error: {message}\n")


def add_version(parser: argparse.ArgumentParser) -> None:
    """``--version``: the console script's name and the installed version, then exit 0."""
    parser.add_argument("--version", action="version", version=version_line(parser.prog),
                        help="print the installed version and exit")


class RenamedFlag(argparse.Action):
    """An old flag name kept so that scripts keep working: its value goes where the new flag's does, and one line on
    stderr says the new name (``sim-vehicle: --waves is now --sea; the old name still works``)."""

    def __init__(self, option_strings: list[str], dest: str, new_name: str = "", **kwargs: Any) -> None:
        super().__init__(option_strings, dest, **kwargs)
        self.new_name = new_name

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        """Store ``values`` as the new flag would, and say the new name once per use."""
        sys.stderr.write(f"{parser.prog}: {option_string} is now {self.new_name} (the old name still works, "
                         "for now)\n")
        setattr(namespace, self.dest, values)


def add_renamed(parser: argparse.ArgumentParser, old: str, new: str, **kwargs: Any) -> None:
    """Keep ``old`` as a deprecated name of the flag ``new`` (already added): same destination, hidden from the
    help, one line naming ``new`` when used. ``kwargs``: the old flag's own ``choices``/``type``."""
    dest = next(a.dest for a in parser._actions if new in a.option_strings)
    parser.add_argument(old, dest=dest, action=RenamedFlag, new_name=new, help=argparse.SUPPRESS, **kwargs)
