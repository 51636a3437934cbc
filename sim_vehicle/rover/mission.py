"""The stored missions (waypoints, fence, rally) as ArduPilot keeps them: seq 0 of a mission is home."""

from __future__ import annotations

import dataclasses
import json
import math
import os
from dataclasses import dataclass, replace
from pathlib import Path

from vessel.config import ConfigError

MISSION, FENCE, RALLY, ALL_TYPES = 0, 1, 2, 255
CAPACITY = 724  # items per mission type
GLOBAL_FRAMES = frozenset({0, 3, 5, 6, 10, 11})
LOCAL_FRAMES = frozenset({1, 4, 7, 8, 9})

NAV_WAYPOINT = 16
NAV_LOITER_UNLIM = 17
NAV_LOITER_TIME = 19
NAV_RETURN_TO_LAUNCH = 20
DO_CHANGE_SPEED = 178
LAST_NAV_COMMAND = 95  # MAV_CMD ids up to here are navigation commands


@dataclass(frozen=True)
class Item:
    """One mission item in MISSION_ITEM_INT form (x/y: degE7 in global frames)."""

    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float

    @property
    def is_nav(self) -> bool:
        """True for navigation commands (those that move the boat and complete)."""
        return self.command <= LAST_NAV_COMMAND


def item_from_int(msg: object) -> Item:
    """Build an Item from a MISSION_ITEM_INT message."""
    return Item(
        int(msg.frame),
        int(msg.command),
        int(msg.current),
        int(msg.autocontinue),
        float(msg.param1),
        float(msg.param2),
        float(msg.param3),
        float(msg.param4),
        int(msg.x),
        int(msg.y),
        float(msg.z),
    )


def item_from_float(msg: object) -> Item | None:
    """Build an Item from a (float) MISSION_ITEM; None if its position cannot be represented."""
    frame = int(msg.frame)
    scale = 1e7 if frame in GLOBAL_FRAMES else 1e4 if frame in LOCAL_FRAMES else 1.0
    x, y = float(msg.x) * scale, float(msg.y) * scale
    if not (math.isfinite(x) and math.isfinite(y)) or abs(x) >= 2**31 or abs(y) >= 2**31:
        return None
    return Item(
        frame,
        int(msg.command),
        int(msg.current),
        int(msg.autocontinue),
        float(msg.param1),
        float(msg.param2),
        float(msg.param3),
        float(msg.param4),
        round(x),
        round(y),
        float(msg.z),
    )


def float_xy(item: Item) -> tuple[float, float]:
    """The item's x/y as a float MISSION_ITEM carries them."""
    scale = 1e7 if item.frame in GLOBAL_FRAMES else 1e4 if item.frame in LOCAL_FRAMES else 1.0
    return item.x / scale, item.y / scale


class MissionStore:
    """Items per mission type, replaced whole (never partially) by a completed upload; optionally on disk."""

    def __init__(self, path: Path | None = None) -> None:
        self._items: dict[int, list[Item]] = {MISSION: [], FENCE: [], RALLY: []}
        self.version = 0  # bumped on every change, so the mission runner can notice
        self.path = path
        if path is not None and path.exists():
            self._load(path)

    def _load(self, path: Path) -> None:
        """Read missions saved by an earlier run; a damaged file is a one-line ConfigError."""
        try:
            saved = json.loads(path.read_text(encoding="utf-8"))
            for key, items in saved.items():
                self._items[int(key)] = [Item(**item) for item in items]
        except (OSError, ValueError, TypeError, KeyError, AttributeError) as exc:
            raise ConfigError(f"{path}: unreadable mission store ({exc}); use --wipe") from None

    def _save(self) -> None:
        """Write every mission type atomically (like ArduPilot keeping its mission in EEPROM)."""
        if self.path is None:
            return
        data = {str(k): [dataclasses.asdict(it) for it in items] for k, items in self._items.items()}
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            tmp = self.path.with_suffix(self.path.suffix + ".tmp")
            tmp.write_text(json.dumps(data, allow_nan=True), encoding="utf-8")
            os.replace(tmp, self.path)
        except OSError:
            pass

    def items(self, mission_type: int) -> list[Item]:
        """The stored items of ``mission_type`` (a copy)."""
        return list(self._items[mission_type])

    def count(self, mission_type: int) -> int:
        """Number of items a download reports (for the mission, home always counts as seq 0)."""
        n = len(self._items[mission_type])
        return max(1, n) if mission_type == MISSION else n

    def replace(self, mission_type: int, items: list[Item]) -> None:
        """Install a complete upload."""
        self._items[mission_type] = [replace(it, current=0) for it in items]
        self.version += 1
        self._save()

    def clear(self, mission_type: int) -> None:
        """Remove every item of ``mission_type`` (or of all types for ALL_TYPES)."""
        for t in (MISSION, FENCE, RALLY) if mission_type == ALL_TYPES else (mission_type,):
            self._items[t] = []
        self.version += 1
        self._save()

    def present(self) -> bool:
        """A mission exists once there is at least one item after home."""
        return len(self._items[MISSION]) >= 2

    def get(self, seq: int) -> Item | None:
        """Mission item ``seq`` (seq 0 is home and is never executed), or None."""
        items = self._items[MISSION]
        return items[seq] if 0 <= seq < len(items) else None
