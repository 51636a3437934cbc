"""The measured state as the NMPC's model can use it: a real hull rides the sea, the paper's model does not.

The prediction model (the paper's) restores heave towards the calm waterline z = 0. A hull that heaves
with the sea is, at any instant, up to a wave amplitude above or below it (0.9 m in the paper's sea) and
moving vertically at up to ζ̇ (0.9 m/s) — without a draft error relative to the local surface. Fed that
state, the model predicts the hull falling back to z = 0, and through its heave–pitch coupling a pitch
and surge that do not happen: measured here on the paper's Balanced run with the hull heaving and the
true wave given to the NMPC, Direct did not reach the waypoint in 180 s and Balanced cut roll by only
22 % (37.9 % with the state below; ``scenarios/estimated.yaml`` with ``estimation.waves: truth``).

``on_mean_surface`` hands the model the hull on its calm waterline instead: down = 0, and the velocity's
vertical NED component removed before it is rotated back into the body frame (η: NED, ν: body).
"""

from __future__ import annotations

import numpy as np

from vessel.sensors import rotation_body_to_ned  # numpy: on the NMPC step (the CasADi one costs ~0.1 ms)


def on_mean_surface(x: np.ndarray) -> np.ndarray:
    """x = [η, ν] (12) with the heave removed: down = 0 m and no vertical NED velocity."""
    out = np.array(x, dtype=float, copy=True)
    R = rotation_body_to_ned(out[3], out[4], out[5])
    velocity_ned = R @ out[6:9]
    velocity_ned[2] = 0.0
    out[2] = 0.0
    out[6:9] = R.T @ velocity_ned
    return out


def resolve_heave_feedback(setting: str, hull_heaves: bool) -> str:
    """``auto`` becomes ``none`` where the hull heaves with the sea (a real boat, the realistic plant)."""
    if setting != "auto":
        return setting
    return "none" if hull_heaves else "measured"
