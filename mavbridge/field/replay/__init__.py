"""`mavbridge replay LOG` (this package: its request and command, ``flight`` the companion's parts flown from the
log, ``source`` what they are fed as the live companion was, ``summary`` what it writes and says; imported by
``mavbridge.field.cli`` only): what the companion would have commanded, fed from a log at the log's own clock.

The companion's own parts, nothing sends: its ``StateEstimate`` takes the log's messages, its wave estimator
(``make_wave_source``, behind its ``WaveGate``) every motion sample, and its NMPC (``build_nmpc``, in
lockstep: each step waits for the solver's background work, as a machine with time to spare would) plans at
the controller's period on the log's clock (``schedule``) towards the log's mission (its ``MissionTracker``
drops each waypoint reached) or ``--waypoint``. The output path (rc_override or attitude_target) is the
companion's, prepared from the log's parameters in a dry run: it computes what it would send and has no link
to send it on. Beside each step are what the boat did (``boat``: the RC inputs the autopilot took and its
motors' outputs) and whether the companion would have been commanding then (armed, in its mode).

The estimator sees what the live companion's saw: the fastest IMU stream of the log (the one the companion
pins after measuring the rates, never the 1 Hz RAW_IMU that arrives first), motion only from when the log shows
the home (the companion's mission download: no position before it), samples on the autopilot's clock; before the
companion would engage (armed, in its mode) its ``WaveGate`` watches the sea, as the live one does, and counts
only the steps it would have commanded, so that ``replay.json``'s first confident time and roll-term share are
the live run's ``metrics.json`` figures. Steps where the companion would not command are still planned (rows
with ``would_command`` 0) on a second gate of their own, counted apart. A companion's own tlog holds what it sent
(RC_CHANNELS_OVERRIDE): each step's command is set beside it (``logged_*``).

The log is read twice: first for its parameters, home, mission and stream rates, then to fly. The NMPC plans
from ``--from`` to ``--to`` (or the arrival). ``DIR/replay.csv``, ``DIR/replay.json`` and ``DIR/replay.png``
are written at the end, in a fresh folder.
"""

from __future__ import annotations

from mavbridge.field.replay.command import ReplayRequest, replay_command

__all__ = ["ReplayRequest", "replay_command"]
