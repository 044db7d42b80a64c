"""Which devices are in alarm, which just came back: the banner across the top of the console.

The session reports alarms as strings ``"<device>: <state> (<error>)"`` in every status snapshot
(:attr:`snrmon.acquisition.runtime.session.SessionStatus.alarms`). The tracker keys them by device,
so a device
going from ``stale`` to ``disconnected`` stays one alarm, and remembers when each one cleared so
the operator sees that a lost device is back, not only that the red went away.
"""

from __future__ import annotations

from dataclasses import dataclass

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QWidget

from snrmon.gui.theme import ALARM, RECOVERED

RECOVERED_SHOWN_S = 15.0


def alarm_source(alarm: str) -> str:
    """The device (or subsystem) an alarm string is about: the text before the first colon."""
    return alarm.split(":", 1)[0].strip()


@dataclass(frozen=True)
class AlarmChange:
    raised: tuple[str, ...]
    cleared: tuple[str, ...]


class AlarmTracker:
    """Folds successive alarm tuples into active alarms and recent recoveries."""

    def __init__(self) -> None:
        self.active: dict[str, str] = {}
        self.recovered: dict[str, float] = {}  # source -> time it came back (s)
        self.log: list[tuple[float, str]] = []

    def update(self, alarms: tuple[str, ...], now_s: float) -> AlarmChange:
        current = {alarm_source(a): a for a in alarms}
        raised = tuple(s for s in current if s not in self.active)
        cleared = tuple(s for s in self.active if s not in current)
        for s in raised:
            self.recovered.pop(s, None)
            self.log.append((now_s, f"LOST {current[s]}"))
        for s in cleared:
            self.recovered[s] = now_s
            self.log.append((now_s, f"BACK {s}"))
        self.active = current
        self.recovered = {s: t for s, t in self.recovered.items() if now_s - t <= RECOVERED_SHOWN_S}
        return AlarmChange(raised, cleared)


class AlarmBanner(QLabel):
    """A red strip listing active alarms; green for a while after a device came back."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.tracker = AlarmTracker()
        self.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.setWordWrap(True)
        self.setToolTip("Device alarms from the session: lost (red) and back again (green).")
        self.setVisible(False)

    def show_alarms(self, alarms: tuple[str, ...], now_s: float) -> AlarmChange:
        change = self.tracker.update(alarms, now_s)
        if self.tracker.active:
            text = "ALARM  " + "   |   ".join(self.tracker.active.values())
            self._paint(text, ALARM)
        elif self.tracker.recovered:
            text = "BACK  " + ", ".join(sorted(self.tracker.recovered)) + " (alarm cleared)"
            self._paint(text, RECOVERED)
        else:
            self.setVisible(False)
        return change

    def _paint(self, text: str, colour: str) -> None:
        if text != self.text():
            self.setText(text)
        self.setStyleSheet(
            f"QLabel {{ background: {colour}; color: white; font-weight: bold; padding: 4px; }}"
        )
        self.setVisible(True)
