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

from vessel.sensors import body_velocity_from_ned, ned_velocity_from_body  # (not CasADi's: ~0.1 ms a step)


def on_mean_surface(x: np.ndarray) -> np.ndarray:
    """x = [η, ν] (12) with the heave removed: down = 0 m and no vertical NED velocity (plain floats: every step)."""
    values = np.asarray(x, dtype=float).ravel().tolist()
    phi, theta, psi, u, v, w = values[3:9]
    north, east, _ = ned_velocity_from_body(phi, theta, psi, u, v, w)
    values[2] = 0.0
    values[6:9] = body_velocity_from_ned(phi, theta, psi, north, east, 0.0)
    return np.array(values)


def resolve_heave_feedback(setting: str, hull_heaves: bool) -> str:
    """``auto`` becomes ``none`` where the hull heaves with the sea (a real boat, the realistic plant)."""
    if setting != "auto":
        return setting
    return "none" if hull_heaves else "measured"
