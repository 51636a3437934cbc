"""Identification: a trial's logs turned into a model of the boat that flew them (`mavbridge identify`).

What lives here: pure estimators on numpy arrays, each giving a value with an interval and a fit figure —
roll and pitch natural period and damping ratio from free decays (``decay``) or from wave- and wake-excited
motion by an AR fit (``ambient``), steady surge speed against the propulsion command (``surge``), a first-order
Nomoto model and the propellers' asymmetry (``yaw``); the arrays a log holds for them (``logdata``, through
``mavbridge.field``'s readers); the identified values turned into ``OtterParameters`` fields and checked on the
vessel plant (``model``); and the command's outputs: identify.json, vessel.yaml and a self-contained page
(``run``, ``figures``, ``page``).

May import ``vessel`` and ``mavbridge.field`` (its log readers and page helpers); imported by ``mavbridge.cli``,
the tests and the benches.
"""
