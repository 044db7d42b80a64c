"""A simulated ASTECH LDM41/42 (Jenoptik-style ASCII) continuous rangefinder on a pty.

Commands (ASTECH manual v1.6 sec. 8): ``DT`` starts tracking output at ``rate_hz``, ESC stops
it, ``DM`` answers one measurement, ``SD d|h|s`` sets the output format, ``SA n`` (1..20) the
averaging; a wrong command or parameter is answered with ``?``. A reading is ``E15`` when
``range_m(t_s)`` is ``None`` (no target).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from snrmon.sim.devices.line_sim import LineSimulator
from snrmon.sim.devices.pty_port import check_baud_budget


def ldm_line(range_m: float | None, fmt: str, quality: int = 900) -> bytes:
    """One output line in format ``d``, ``h`` or ``s``."""
    if range_m is None:
        return b"E15\r\n"
    if fmt == "h":
        mm = round(range_m * 1000) & 0xFFFFFF
        return f" {mm:06X}\r\n".encode()
    if fmt == "s":
        return f"{range_m:07.3f} {quality:06d}\r\n".encode()
    return f"{range_m:07.3f}\r\n".encode()


class LdmSimulator(LineSimulator):
    """An LDM41/42.

    Args:
        range_m: ``range_m(t_s) -> float | None``.
        rate_hz: tracking output rate.
        quality: signal quality reported in format ``s`` (0..1024).
        tracking: start in tracking mode (the ``AS DT`` autostart setting).
        baud: default 9600.
        link_path, seed: see :class:`LineSimulator`.
    """

    def __init__(
        self,
        range_m: Callable[[float], float | None],
        *,
        rate_hz: float = 10.0,
        quality: int = 900,
        tracking: bool = False,
        baud: int = 9600,
        link_path: str | Path | None = None,
        seed: int = 0,
    ) -> None:
        super().__init__(baud=baud, link_path=link_path, seed=seed)
        self.range_m = range_m
        self.tick_period_s = 1.0 / rate_hz
        self.quality = quality
        self.tracking = tracking
        self.fmt = "d"
        self.averaging = 1
        check_baud_budget(rate_hz * 16, baud, f"LDM tracking at {rate_hz:g} Hz")

    def reading(self, t_s: float) -> bytes:
        r = None if self.faults.take_no_target() else self.range_m(t_s)
        return ldm_line(r, self.fmt, self.quality)

    def handle(self, command: str, t_s: float) -> list[bytes]:
        if command.endswith("\x1b"):
            self.tracking = False
            return []
        cmd = command.strip().upper()
        if cmd == "DT":
            self.tracking = True
            return []
        if cmd == "DM":
            self.tracking = False
            return [self.reading(t_s)]
        if cmd.startswith("SD") and cmd[2:].strip().lower() in ("d", "h", "s"):
            self.fmt = cmd[2:].strip().lower()
            return []
        if cmd.startswith("SA") and cmd[2:].strip().isdigit() and 1 <= int(cmd[2:]) <= 20:
            self.averaging = int(cmd[2:])
            return []
        return [b"?\r\n"]

    def tick(self, t_s: float) -> list[bytes]:
        return [self.reading(t_s)] if self.tracking else []
