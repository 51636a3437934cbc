"""GUIDED's tau form: the targets that make Rover's own loops give the NMPC's throttle and steering.

``inverse``: Rover's turn-rate and speed loops (feed-forward and P) inverted, their gains read at start;
``feedback``: the motors' PWM seen in SERVO_OUTPUT_RAW, so that what Rover's integrators add is corrected
rather than assumed off. Used by the companion's output paths (``mavbridge.companion.output_paths``) and
judged by `mavbridge check` (``mavbridge.preflight.rules``).

May import: ``vessel``, ``mavbridge.link`` and ``mavbridge.companion.outputs``; imported by
``mavbridge.companion``, ``mavbridge.preflight`` and ``mavbridge.field``.
"""
