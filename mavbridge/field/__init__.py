"""Field logs: reading a trial's logs that the project did not write, and turning them into pictures.

Readers for a ground station's MAVLink ``.tlog`` (any ground station, any autopilot system id), ArduPilot's
DataFlash ``.bin``/``.log`` (pymavlink's DFReader) and the Otter API's semicolon CSV, each streaming the
autopilot's messages in MAVLink's own vocabulary on one timeline (``logs``); the trial those messages make
through the companion's own ``StateEstimate`` (``trial``), its mode segments and our companion's engagements
(``segments``), the sea the companion's ``WaveEstimator`` sees replayed over it (``sea``; the reading in a
child process beside it, ``pipeline``), the roll spectrum, the figures and the self-contained HTML page of
`mavbridge report` (``report``, ``figures``, ``page``), and `mavbridge replay`: the companion's state,
estimator, NMPC and output path fed from the log at its own clock beside what the boat did (``boat``),
sending nothing (``replay``).

May import ``vessel``, ``mavbridge.link`` (pymavlink's dialect), ``mavbridge.companion``, ``mavbridge.waves``
(its public interface only), ``mavbridge.nmpc``, ``mavbridge.lab`` (the run log's columns and folders),
``mavbridge.preflight.rules`` (the context an output path is judged in) and ``mavbridge.cli``'s argument
types; imported by ``mavbridge.cli``, the tests and the benches.
"""
