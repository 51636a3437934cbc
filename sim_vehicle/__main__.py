"""``python -m sim_vehicle``: the same as the ``sim-vehicle`` command."""

import sys

from sim_vehicle.cli import main

sys.exit(main())
