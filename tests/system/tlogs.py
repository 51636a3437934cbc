"""Checks on the two tlogs of a run (issue 17 item 12): on one clock, and each message logged once."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from pymavlink import mavutil

STAMP_TOLERANCE_S = 0.002  # both stamp a message time_boot_ms = T at boot epoch + T (µs rounding, ≤ 1 ms each)


def attitudes(tlog: Path) -> list[tuple[float, int, bytes]]:
    """(tlog stamp s, time_boot_ms, payload) of every ATTITUDE in ``tlog``, read with pymavlink."""
    log = mavutil.mavlink_connection(str(tlog), dialect="ardupilotmega")
    found = []
    while (msg := log.recv_match(type="ATTITUDE")) is not None:
        found.append((msg._timestamp, msg.time_boot_ms, bytes(msg.get_payload())))
    return found


def assert_each_attitude_once(tlog: Path) -> None:
    """No ATTITUDE is in the log twice (identical content would need a repeated time_boot_ms, and the
    autopilot's clock never stands still between two samples of one stream)."""
    rows = attitudes(tlog)
    repeated = {t: n for t, n in Counter(t for _, t, _ in rows).items() if n > 1}
    assert rows and not repeated, f"{tlog.name}: {len(repeated)} time_boot_ms logged more than once, e.g. " \
                                  f"{sorted(repeated.items())[:5]}"


def assert_tlogs_line_up(sim_tlog: Path, companion_tlog: Path, min_common: int) -> None:
    """The same ATTITUDE (same time_boot_ms) has the same stamp in both logs, to STAMP_TOLERANCE_S."""
    sim = {t: stamp for stamp, t, _ in attitudes(sim_tlog)}
    companion = {t: stamp for stamp, t, _ in attitudes(companion_tlog)}
    common = sorted(set(sim) & set(companion))
    assert len(common) >= min_common, f"only {len(common)} ATTITUDE samples in both logs"
    worst = max(common, key=lambda t: abs(sim[t] - companion[t]))
    assert abs(sim[worst] - companion[worst]) <= STAMP_TOLERANCE_S, \
        f"ATTITUDE time_boot_ms {worst}: stamped {sim[worst]:.6f} s by the simulator, {companion[worst]:.6f} s " \
        f"by the companion"
    span_ms = common[-1] - common[0]
    assert abs((companion[common[-1]] - companion[common[0]]) * 1000 - span_ms) <= 2, "not on the autopilot clock"
