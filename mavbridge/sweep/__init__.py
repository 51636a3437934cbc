"""``mavbridge sweep``: many in-process closed loops over axes of a base scenario, on a pool or a Dask cluster."""

from .executors import open_executor, parse_executor
from .runner import SweepOutcome, run_case, run_sweep
from .spec import Case, SweepSpec, case_id, load_spec

__all__ = ["Case", "SweepOutcome", "SweepSpec", "case_id", "load_spec", "open_executor", "parse_executor",
           "run_case", "run_sweep"]
