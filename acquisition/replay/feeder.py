"""Plays a recording's timeline into a session engine: the same engine the live console runs.

:class:`Feeder` applies one timeline entry at a time (:meth:`Feeder.apply`): a rangefinder
reading or GPS fix as it arrived, a recorded stop event (the stop open at the session's end makes
every row final, as the live session's end did), or one camera frame with the commands
recorded at it (an engine state after a recording gap first, then the clicks, the background
reference, the GPS cue), then the frame itself through the engine. A frame the live engine measured
but the recorder dropped is not re-measured: its recorded measurement goes into the table and the
charts as it was, and the engine state recorded before the next recorded frame takes over. So every
recorded frame's SNR is reproduced exactly, and the stop table equals the live one.

Frames are read as late and as little as possible: ``fast`` hands the engine a read-only view of
the frame inside a memory map of the file (only the pages the measurement touches are read: a few
kB around the track); otherwise the whole frame is read through h5py.
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass, field

import numpy as np

from snrmon.acquisition.engine.inputs import (
    ApplyReference,
    ClearReference,
    ClearRoi,
    Cue,
    FrameOutput,
    Measurement,
    Restore,
    SetRoi,
)
from snrmon.acquisition.engine.session_engine import SessionEngine
from snrmon.acquisition.measure.peak_snr import flags_from_bits
from snrmon.acquisition.record.frame_access import FrameCrops
from snrmon.acquisition.record.reader import SessionFile
from snrmon.acquisition.record.schema import text_value
from snrmon.acquisition.record.stream_rows import (
    fix_from_row,
    measurement_from_row,
    reading_from_row,
    track_state_of,
)
from snrmon.acquisition.replay.recorded import (
    FIX,
    FRAME,
    RANGE,
    STOP,
    RecordedInputs,
    frames_between,
)
from snrmon.acquisition.stops.detector import Stop
from snrmon.acquisition.streams.ring import RingFrame

log = logging.getLogger(__name__)


class RecordedStops:
    """The stops as the live detector found them (format 2 records their times): a replay uses
    them instead of detecting again, so its table is the live one even where the readings of two
    devices arrived in a different order than their time stamps say."""

    def __init__(self) -> None:
        self._stops: list[Stop] = []

    @property
    def stops(self) -> list[Stop]:
        return list(self._stops)

    def apply(self, stop: Stop) -> None:
        if stop.index < len(self._stops):
            self._stops[stop.index] = stop
        elif stop.index == len(self._stops):
            self._stops.append(stop)
        else:
            raise ValueError(f"recorded stop {stop.index} follows stop {len(self._stops) - 1}")


@dataclass
class CameraTally:
    """What a replay did with one camera's frames."""

    name: str
    frames_in_file: int = 0
    measured: int = 0  # frames measured again
    not_in_file: int = 0  # measured live, pixels dropped by the recorder: recorded values used
    before_recording: int = 0  # measured live before the recording began (rows without frames)
    compared: int = 0
    identical: int = 0
    states_restored: int = 0
    first_difference: int | None = None  # counter of the first frame that differs
    measurements: list[Measurement] = field(default_factory=list)


def _same(a: float, b: float) -> bool:
    return a == b or (a != a and b != b)  # NaN equals NaN


@functools.lru_cache(maxsize=256)
def _flags(bits: int) -> frozenset[str]:
    return flags_from_bits(bits)


def same_result(row, m: Measurement) -> bool:
    """The replayed frame reads exactly what the live one recorded: Eq. (4) (peak, SNR,
    flags) and, where the file has them (format 2), the running statistics after it and the
    track's state and window. ``row``: a measurement row (np.void, or a dict of its fields
    :data:`_ROW_FIELDS`); the fields compared are those of :func:`peak_snr_from_row`, read
    without building it."""
    r = m.result
    same = (
        _same(float(row["snr"]), r.snr)
        and int(row["peak_x"]) == r.peak_x
        and int(row["peak_y"]) == r.peak_y
        and _flags(int(row["flags"])) == r.flags
        and text_value(row["background"]) == r.background
    )
    if same and bytes(row["track_state"]):  # format 2
        same = (
            _same(float(row["snr_mean"]), m.snr_mean)
            and _same(float(row["snr_std"]), m.snr_std)
            and int(row["snr_n"]) == m.snr_n
            and (int(row["window_x"]), int(row["window_y"])) == m.window_xy
            and track_state_of(row) is m.track_state
        )
    return same


_ROW_FIELDS = (
    *("snr", "peak_x", "peak_y", "flags", "background", "track_state"),
    *("snr_mean", "snr_std", "snr_n", "window_x", "window_y", "cue_x", "cue_y"),
)
"""The fields of a measurement row a replay compares (:func:`same_result`) or applies (the
GPS cue)."""


class Feeder:
    """Applies a recording's timeline to ``engine`` (module docstring).

    Args:
        f: the open session file.
        inputs: what it recorded (:func:`snrmon.acquisition.replay.recorded.recorded_inputs`).
        engine: a fresh engine built from the recording's settings.
        fast: read frames through a memory map (same numbers, a few kB a frame).
        recorded_stops: the stop source the engine was built with, when the file's own stops
            are used (None: the engine detects them from the readings).
        keep: keep every measurement in the tallies (batch replay; the console does not).
    """

    def __init__(
        self,
        f: SessionFile,
        inputs: RecordedInputs,
        engine: SessionEngine,
        *,
        fast: bool = False,
        recorded_stops: RecordedStops | None = None,
        keep: bool = True,
    ) -> None:
        self.f = f
        self.inputs = inputs
        self.engine = engine
        self.recorded_stops = recorded_stops
        self.keep = keep
        self.exact_inputs = inputs.version >= 2
        self.tally = {n: CameraTally(n, f.cameras[n].n_frames) for n in inputs.cameras}
        self.fast = fast
        self._crops: dict[str, FrameCrops] = {}  # made at a camera's first frame (fast only)
        self._references: dict[tuple[str, int], np.ndarray] = {}  # (camera, index): image
        self._next_command = dict.fromkeys(inputs.cameras, 0)
        self._next_model_input = dict.fromkeys(inputs.cameras, 0)
        self._columns: dict[str, dict[str, list]] = {}  # per camera (_columns_of)
        self._entries: list[tuple[int, int, int, int, int]] | None = None  # the timeline
        self._counters: dict[str, list[int]] = {}  # each camera's frame counters

    # ------------------------------------------------------------------ seeking
    def skip_to(self, k: int) -> None:
        """Prepare a fresh engine to show entry ``k`` without measuring what comes before:
        readings and stops up to it are applied; per camera the background reference in force
        and the track at its last recorded window (not the full recorded state: a seek starts
        the measurement afresh there; running statistics restart)."""
        tl = self.inputs.timeline
        t_k = int(tl["t_ns"][k])
        for j in range(k):
            if int(tl["kind"][j]) != FRAME:
                self.apply(j)
        for name in self.inputs.cameras:
            c = self.inputs.per_camera[name]
            engine = self.engine.cameras[name]
            i = self._next_command[name]
            roi, roi_t, reference = None, 0, None
            while i < len(c.commands) and c.commands[i][0] < t_k:
                t_c, kind, p = c.commands[i]
                i += 1
                if kind in ("roi_set", "roi_cleared"):
                    roi = (int(p["x"]), int(p["y"])) if kind == "roi_set" else None
                    roi_t = t_c
                elif kind == "background_reference":
                    reference = p
                elif kind == "reference_cleared":
                    reference = None
            self._next_command[name] = i
            self._apply_model_inputs(name, t_k, inclusive=False)
            if reference is not None:
                engine.post(self._reference(name, reference))
            meas = self.f.cameras[name].measurements
            before = meas[(meas["t_host_ns"] >= roi_t) & (meas["t_host_ns"] < t_k)]
            if roi is not None and before.size:
                last = before[-1]  # where the recorded track was when the seek cut it
                roi = (int(last["window_x"]), int(last["window_y"]))
            if roi is not None:
                engine.post(SetRoi(*roi))

    # ------------------------------------------------------------------ one entry
    def apply(self, k: int) -> tuple[str, FrameOutput | Measurement | None] | None:
        """Apply timeline entry ``k``; for a frame, returns (camera, what it gave)."""
        if self._entries is None:  # the timeline's columns as Python ints, once
            tl = self.inputs.timeline
            columns = (tl[f].tolist() for f in ("kind", "camera", "frame", "row", "t_ns"))
            self._entries = list(zip(*columns, strict=True))
        kind, camera, frame, row, t_ns = self._entries[k]
        if kind == RANGE:
            self.engine.on_range(reading_from_row(self.f.rangefinder[row]))
        elif kind == FIX:
            self.engine.on_fix(fix_from_row(self.f.gps[row]))
        elif kind == STOP:
            if self.recorded_stops is not None:
                stop_kind, stop = self.inputs.stops[row]
                self.recorded_stops.apply(stop)
                if stop_kind == "stop_open_at_end":
                    # the live session ended here: its rows were made final as they stood (a
                    # player reaching the end shows them so, as a batch replay's finalize does)
                    self.engine.finalize()
        elif kind == FRAME:
            name = self.inputs.cameras[camera]
            return name, self._frame(name, frame, row, t_ns)
        return None

    def _frame(self, name: str, i: int, r: int, t: int):
        cam = self.f.cameras[name]
        tally = self.tally[name]
        row = None
        if r >= 0:  # the fields compared and applied, from the columns as Python values
            row = {k: column[r] for k, column in self._columns_of(name).items()}
        if i < 0:  # measured live, not in the file
            assert row is not None  # a timeline entry without a frame always has its row
            m = measurement_from_row(name, cam.measurements[r])
            self.engine.on_recorded(m)
            if cam.n_frames and t < int(cam.t_host_ns[0]):
                tally.before_recording += 1
            else:
                tally.not_in_file += 1
            if self.keep:
                tally.measurements.append(m)
            self._after(name, t)
            return m
        counters = self._counters.get(name)
        if counters is None:
            counters = self._counters[name] = cam.counter.tolist()
        counter = counters[i]
        self._post_commands(name, counter, t, row)
        pixels = self._pixels(name, i)
        out = self.engine.on_frame(RingFrame(pixels, i, counter, t, None, name))
        measured = out.measurement
        if measured is not None:
            m = measured
            tally.measured += 1
            if self.keep:
                tally.measurements.append(m)
            if row is not None:
                tally.compared += 1
                if same_result(row, m):
                    tally.identical += 1
                elif tally.first_difference is None:
                    tally.first_difference = m.counter
        self._after(name, t)
        return out

    def _columns_of(self, name: str) -> dict[str, list]:
        """The measurement rows' fields :func:`same_result` and :meth:`_post_commands` read,
        column by column as Python lists (once per camera: a row's own conversion costs more
        than the comparison)."""
        columns = self._columns.get(name)
        if columns is None:
            rows = self.f.cameras[name].measurements
            columns = self._columns[name] = {k: rows[k].tolist() for k in _ROW_FIELDS}
        return columns

    def _after(self, name: str, t: int) -> None:
        self._apply_model_inputs(name, t, inclusive=True)

    def _apply_model_inputs(self, name: str, t: int, *, inclusive: bool) -> None:
        """The model's recorded input changes (the measured sky, a measured PSF) up to ``t``."""
        inputs = self.inputs.per_camera[name].model_inputs
        k = self._next_model_input[name]
        while k < len(inputs) and (inputs[k][0] <= t if inclusive else inputs[k][0] < t):
            if self.exact_inputs:
                self.engine.apply_model_input(name, inputs[k][1], inputs[k][2])
            k += 1
        self._next_model_input[name] = k

    def held_in_memory(self, name: str) -> bool:
        """Read now what ``name``'s replay would later read through HDF5 (the reference images
        its commands name) and map its frames (``fast``); True when nothing of it is then left
        to read through HDF5: every frame in the memory map, every reference read (format 2).
        A process forked from this one can then play it without touching the open file
        (:mod:`snrmon.acquisition.replay.forked`)."""
        if not self.fast or self.inputs.version < 2:
            return False
        cam = self.f.cameras[name]
        crops = self._frame_crops(name)
        if crops.frames_mapped < cam.n_frames:
            return False
        for _, kind, payload in self.inputs.per_camera[name].commands:
            if kind != "background_reference":
                continue
            if self._reference_image(name, payload.get("reference_index")) is None:
                return False  # format 1: rebuilt from its frames, through h5py
        return True

    def _frame_crops(self, name: str) -> FrameCrops:
        crops = self._crops.get(name)
        if crops is None:
            crops = self._crops[name] = FrameCrops(self.f.cameras[name].frames)
        return crops

    def _pixels(self, name: str, i: int) -> np.ndarray:
        crops = self._frame_crops(name) if self.fast else None
        if crops is not None:
            view = crops.frame_view(i)
            if view is not None:
                return view
        return self.f.cameras[name].frames[i]

    def _post_commands(self, name: str, counter: int, t: int, row) -> None:
        engine = self.engine.cameras[name]
        c = self.inputs.per_camera[name]
        state = c.states.get(counter)
        k = self._next_command[name]
        if state is not None and self.exact_inputs:
            engine.post(Restore(state))
            self.tally[name].states_restored += 1
            # Commands applied live at frames the file does not hold are in the state already.
            while k < len(c.commands) and c.commands[k][0] < t:
                k += 1
        while k < len(c.commands) and c.commands[k][0] <= t:
            _, kind, p = c.commands[k]
            k += 1
            if kind == "roi_set":
                engine.post(SetRoi(int(p["x"]), int(p["y"])))
            elif kind == "roi_cleared":
                engine.post(ClearRoi())
            elif kind == "background_reference":
                engine.post(self._reference(name, p))
            elif kind == "reference_cleared":
                engine.post(ClearReference())
        self._next_command[name] = k
        if self.exact_inputs and row is not None:
            cx, cy = float(row["cue_x"]), float(row["cue_y"])
            if cx == cx and cy == cy:  # finite: a cue was applied before this frame live
                engine.post(Cue(cx, cy))

    def _reference_image(self, name: str, k: int | None) -> np.ndarray | None:
        """The recorded reference image ``k`` of ``name`` (read once); None when the file
        does not hold it (format 1)."""
        if k is None:
            return None
        image = self._references.get((name, int(k)))  # first: no HDF5 call once read
        if image is None:
            refs = self.f.cameras[name].references
            if refs is None or not k < refs.shape[0]:
                return None
            image = self._references[(name, int(k))] = np.asarray(refs[int(k)], np.float32)
        return image

    def _reference(self, name: str, payload: dict) -> ApplyReference:
        cam = self.f.cameras[name]
        offset = self._reference_image(name, payload.get("reference_index"))
        if offset is not None:
            # "in_force": recorded at the start of a recording or after a gap, not a capture
            # that just ended: the raw track is not restarted by it.
            return ApplyReference(offset, payload, restart_raw=not payload.get("in_force"))
        # Format 1: rebuild it from its frames, through the live accumulation.
        engine = self.engine.cameras[name]
        frames, counters = frames_between(
            cam, int(payload["first_counter"]), int(payload["last_counter"])
        )
        corrector = type(engine.corrector)(engine.shape, engine.corrector.half_px)
        corrector.calibration = engine.corrector.calibration
        summary = corrector.set_reference(frames, counters)
        assert corrector.reference_offset is not None
        return ApplyReference(corrector.reference_offset, summary)
