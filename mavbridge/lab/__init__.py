"""The in-process lab: scenarios (a world plus mission, controller and experiment settings), the
closed-loop experiment runner, the run record (CSV schema, metrics), the paper's plots,
`mavbridge demo` (the whole system as separate processes over UDP loopback), and what the computer does to a timed
step (``machine``: the step bench's spinners, the collector's passes, the cold factor).

May import ``vessel``, ``mavbridge.nmpc``, ``mavbridge.waves`` and ``mavbridge.companion``'s pure parts;
imported by ``mavbridge.cli``, ``mavbridge.sweep``, ``mavbridge.companion`` (scenario, run log) and benches.
"""
