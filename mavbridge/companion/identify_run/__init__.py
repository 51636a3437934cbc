"""The identification run: `mavbridge run --identify` flies a short scripted sequence instead of the NMPC.

``sequence`` holds the sequence as data (throttle steps, a 20°/20° zig-zag, hard turns braked and released) and
the small state machine that turns it into throttle and steering each control period, on autopilot time.
``flight`` is the companion that flies it on the RC override path, with the run's consent, mode and arming rules
and a range and a time limit, and leaves an ordinary run folder for `mavbridge identify`.

May import: ``vessel``, ``mavbridge.link``, ``mavbridge.companion`` (the run it specialises); imported by
``mavbridge.cli`` only.
"""
