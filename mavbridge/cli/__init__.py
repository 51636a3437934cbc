"""``mavbridge``'s command lines: the parser and dispatch (``main``), the argument types and loaders the
subcommands share, `run`/`demo` (and `run --realtime`'s scheduling, locked memory and CPU: ``realtime``), and
`signing setup`. ``python -m mavbridge.cli`` is the console script.

May import every ``mavbridge`` package (lazily, so that ``--help`` stays quick); imported by nothing of
ours but tests and the benches.
"""
from mavbridge.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
