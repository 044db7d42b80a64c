"""``snrmon doctor``: the go/no-go an operator runs before the drone flies.

Each check gives one :class:`Check`: pass, fail or skip, what it found, and for a failure the
fix in words an operator can act on. A check is *needed* when the session config (or, without
one, this machine as a console) depends on it; the command exits 0 only when every needed check
passes. A failed check that is not needed is shown as a warning.

Modules: :mod:`.qt` (the console's window on this display), :mod:`.ports` (serial ports and
the user's access), :mod:`.backends` (libusb, V4L2, Aravis), :mod:`.devices` (each configured
device answers: camera rate, rangefinder, GPS fix, its age and the host clock), :mod:`.disk`
(sequential write speed against the cameras' data rate, free space for the planned duration),
:mod:`.compiled` (the per-frame analysis compiles or loads), :mod:`.runner` (which checks a
config needs, in what order).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

PASS, FAIL, SKIP = "pass", "fail", "skip"


@dataclass
class Check:
    """One check's outcome.

    Attributes:
        name: short key (``qt-display``, ``port:gps``, ``camera:mwir``, ``disk-speed``).
        status: ``pass``, ``fail`` or ``skip`` (not applicable here).
        detail: what was found, with the numbers.
        fix: what to do about a failure (empty when it passed).
        needed: whether the session needs it; only needed failures fail the doctor.
        data: the measured numbers (fps, MB/s, seconds), null where not measured.
    """

    name: str
    status: str
    detail: str
    fix: str = ""
    needed: bool = True
    data: dict[str, Any] = field(default_factory=dict)

    @property
    def label(self) -> str:
        """PASS, FAIL, WARN (a failure not needed here) or SKIP."""
        if self.status == FAIL and not self.needed:
            return "WARN"
        return self.status.upper()


def all_needed_pass(checks: list[Check]) -> bool:
    """True when no needed check failed."""
    return not any(c.status == FAIL and c.needed for c in checks)
