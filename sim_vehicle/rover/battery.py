"""The Otter's battery as the autopilot reports it: a simple energy account driven by the motor outputs."""

from __future__ import annotations

from dataclasses import dataclass

BATTERY_CAPACITY_MAH = 96000.0  # the Otter's 4 x 24 Ah packs
BATTERY_VOLTS = 25.2


@dataclass
class Battery:
    """A simple energy account: current from propeller demand, remaining charge by coulomb counting."""

    consumed_mah: float = 0.0
    current_a: float = 1.0

    def update(self, outputs: tuple[float, float], dt: float) -> None:
        """Hotel load plus a thruster load rising with |output|^1.5 (40 A per motor at full power)."""
        self.current_a = 1.0 + 40.0 * sum(abs(o) ** 1.5 for o in outputs)
        self.consumed_mah += self.current_a * dt / 3.6

    @property
    def remaining_pct(self) -> int:
        """Remaining charge, %."""
        return max(0, min(100, round(100.0 * (1.0 - self.consumed_mah / BATTERY_CAPACITY_MAH))))

    @property
    def voltage_mv(self) -> int:
        """Pack voltage sagging slightly with load and charge used, mV."""
        return round(
            1000.0 * (BATTERY_VOLTS - 0.02 * self.current_a - 3.0 * self.consumed_mah / BATTERY_CAPACITY_MAH)
        )
