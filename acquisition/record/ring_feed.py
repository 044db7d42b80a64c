"""Feeding a recorder straight from a frame ring (a recording without a measurement thread in
between, e.g. a raw capture): one pump thread per camera pops every frame in order."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

from snrmon.acquisition.streams.ring import Reader

if TYPE_CHECKING:
    from snrmon.acquisition.record.recorder import SessionRecorder


def pump_reader(recorder: SessionRecorder, camera: str, reader: Reader) -> threading.Thread:
    """Start a thread that adds every frame ``reader`` pops to ``recorder`` as ``camera``. When
    the recorder begins to stop, the pump takes what was pushed up to then and closes the reader
    (the recorder owns it from now on). Frames the reader loses are its own overruns, counted by
    the ring."""

    def pump() -> None:
        end_seq = None  # frames pushed when stop() began: drain up to there, then leave
        try:
            while recorder.accepting:
                if end_seq is None and recorder.draining:
                    end_seq = reader.ring.pushed
                if end_seq is not None and reader.lag == 0:
                    return
                item = reader.pop_next(timeout=0.05)
                if item is not None:
                    recorder.add_frame(camera, item)
                    if end_seq is not None and item.seq >= end_seq - 1:
                        return
        finally:
            reader.close()

    t = threading.Thread(target=pump, name=f"recorder-pump-{camera}", daemon=True)
    t.start()
    return t
