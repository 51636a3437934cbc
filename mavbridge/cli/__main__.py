"""``python -m mavbridge.cli``: the same as the ``mavbridge`` command."""

from mavbridge.cli.main import main

raise SystemExit(main())
