"""A simulated Laser Technology TruPulse 360R on a pty (CR400 ``$PLTIT`` protocol).

It answers the 360R's remote commands (``$GO`` fire, ``$ST`` stop, ``$MM,n``, ``$DU,0``,
``$TM,n``, ``$AU,0``, ``$BV``, ``$PLTIT,RQ,ID``) with ``$OK`` or the documented reply, stays
silent on anything it does not know (as the CR400 does), and after ``$GO`` sends the shot:
``$PLTIT,HV,...`` or ``$E01`` when ``range_m(t_s)`` is ``None`` (no target).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

from snrmon.sim.devices.line_sim import LineSimulator, sentence
from snrmon.sim.devices.pty_port import check_baud_budget

UNIT_FROM_M = {"M": 1.0, "F": 1 / 0.3048, "Y": 1 / 0.9144}


def hv_sentence(
    slope_m: float | None,
    inclination_deg: float,
    azimuth_deg: float,
    *,
    unit: str = "M",
    low_quality: bool = False,
) -> bytes:
    """``$PLTIT,HV`` for one shot; distances rounded to 0.1 and the quality digit appended."""
    inc = f"{inclination_deg:.1f}0"
    az = f"{azimuth_deg % 360:.1f}0"
    if slope_m is None:
        return sentence(f"PLTIT,HV,,,{az},D,{inc},D,,")
    q = "1" if low_quality else "0"
    k = UNIT_FROM_M[unit]
    sd = f"{slope_m * k:.1f}{q}"
    hd = f"{slope_m * math.cos(math.radians(inclination_deg)) * k:.1f}{q}"
    return sentence(f"PLTIT,HV,{hd},{unit},{az},D,{inc},D,{sd},{unit}")


class TruPulseSimulator(LineSimulator):
    """A TruPulse 360R.

    Args:
        range_m: ``range_m(t_s) -> float | None``; ``None`` is a shot with no target.
        inclination_deg, azimuth_deg: the pointing reported with each shot.
        unit: distance unit before a ``$DU,0`` arrives ("M", "F" or "Y").
        low_quality: report the low-quality target digit.
        auto_fire_hz: also fire on its own at this rate (an operator holding the trigger).
        baud: default 4800.
        link_path, seed: see :class:`LineSimulator`.
    """

    model = "TP360R"

    def __init__(
        self,
        range_m: Callable[[float], float | None],
        *,
        inclination_deg: float = 5.0,
        azimuth_deg: float = 0.0,
        unit: str = "M",
        low_quality: bool = False,
        auto_fire_hz: float | None = None,
        baud: int = 4800,
        link_path: str | Path | None = None,
        seed: int = 0,
    ) -> None:
        if unit not in UNIT_FROM_M:
            raise ValueError(f"TruPulse simulator unit must be M, F or Y, got {unit!r}")
        super().__init__(baud=baud, link_path=link_path, seed=seed)
        self.range_m = range_m
        self.inclination_deg, self.azimuth_deg = inclination_deg, azimuth_deg
        self.unit, self.low_quality = unit, low_quality
        self.auto_fire_hz = auto_fire_hz
        self.tick_period_s = 1.0 / auto_fire_hz if auto_fire_hz else 0.1
        self.shots = 0
        if auto_fire_hz:
            check_baud_budget(auto_fire_hz * 48, baud, f"TruPulse firing at {auto_fire_hz:g} Hz")

    def shot(self, t_s: float) -> bytes:
        self.shots += 1
        r = None if self.faults.take_no_target() else self.range_m(t_s)
        if r is None:
            return b"$E01\r\n"
        return hv_sentence(
            r, self.inclination_deg, self.azimuth_deg, unit=self.unit, low_quality=self.low_quality
        )

    def handle(self, command: str, t_s: float) -> list[bytes]:
        if command == "$GO":
            return [b"$OK\r\n", self.shot(t_s)]
        if command == "$PLTIT,RQ,ID":
            return [sentence(f"PLTIT,ID,{self.model},2.10,")]
        if command == "$BV":
            return [b"$BV,2950\r\n"]
        if command == "$DU,0":
            self.unit = "M"
            return [b"$OK\r\n"]
        if command in ("$ST", "$AU,0", "$PO") or command[:4] in ("$MM,", "$TM,", "$DE,"):
            return [b"$OK\r\n"]
        return []  # the CR400 does not answer what it does not understand

    def tick(self, t_s: float) -> list[bytes]:
        return [self.shot(t_s)] if self.auto_fire_hz else []
