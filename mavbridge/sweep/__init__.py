"""``mavbridge sweep``: many in-process closed loops over axes of a base scenario, on a pool or a Dask cluster.

May import: ``vessel``, ``mavbridge.lab`` (scenarios, experiments), ``mavbridge.nmpc`` and
``mavbridge.cli.args`` (argument types). Imported by
``mavbridge.cli`` and benches.
"""

from mavbridge.sweep.executors import open_executor, parse_executor
from mavbridge.sweep.runner import SweepOutcome, run_case, run_sweep
from mavbridge.sweep.spec import Case, SweepSpec, case_id, load_spec

__all__ = ["Case", "SweepOutcome", "SweepSpec", "case_id", "load_spec", "open_executor", "parse_executor",
           "run_case", "run_sweep"]
