"""Drop accounting from a camera's own frame counter (ACQ4 and Aravis ``frame_id`` style)."""

from __future__ import annotations


class FrameCounterGaps:
    """Turns successive camera frame counters into counts of frames the camera side lost.

    Args:
        modulus: the counter wraps to 0 (or to 1 with ``zero_skipped``) after ``modulus - 1``;
            ``None`` for a counter that never wraps (64-bit).
        zero_skipped: the counter never takes the value 0 after wrapping (GigE Vision 1.x
            16-bit block ids run 1..65535, then 1 again).
    """

    def __init__(self, modulus: int | None = None, *, zero_skipped: bool = False) -> None:
        self.modulus = modulus
        self.zero_skipped = zero_skipped
        self.last: int | None = None
        self.dropped = 0
        self.resets = 0

    def reset(self) -> None:
        """Forget the last counter (after a reconnect the camera may restart its count)."""
        self.last = None

    def update(self, counter: int) -> int:
        """Record ``counter``; return how many frames are missing between it and the last one.

        A counter that repeats or goes backwards (without a wrap) is a camera reset: 0 missing.
        """
        last, self.last = self.last, counter
        if last is None:
            return 0
        step = counter - last
        if self.modulus is not None and step < 0:
            span = self.modulus - (1 if self.zero_skipped else 0)
            wrapped = step + span
            # Only a step that lands just past the wrap is a wrap; far back is a reset.
            if 0 < wrapped <= span // 2:
                step = wrapped
        if step <= 0:
            self.resets += 1
            return 0
        missing = step - 1
        self.dropped += missing
        return missing
