"""``python -m sim_vehicle``: the same as the ``sim-vehicle`` command."""

import sys

from .cli import main

sys.exit(main())
