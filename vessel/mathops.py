"""Pick the maths backend for a value, so one formula serves floats, numpy arrays and CasADi symbols."""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np


def is_symbolic(*values: Any) -> bool:
    """True if any value is a CasADi matrix (SX, MX or DM)."""
    return any(isinstance(v, (ca.SX, ca.MX, ca.DM)) for v in values)


def ops(*values: Any) -> Any:
    """The module whose sin/cos/fmin/fmax/fabs apply to these values: casadi for symbols, else numpy."""
    return ca if is_symbolic(*values) else np


def where(condition: Any, if_true: Any, if_false: Any) -> Any:
    """Element-wise choice that works on numpy values and CasADi symbols."""
    if is_symbolic(condition, if_true, if_false):
        return ca.if_else(condition, if_true, if_false)
    return np.where(condition, if_true, if_false)


def arctan(value: Any) -> Any:
    """atan for both backends (numpy spells it arctan)."""
    return ca.atan(value) if is_symbolic(value) else np.arctan(value)
