"""What a replay applies, read once from a session file: the recorded devices on the recorded clock.

:func:`recorded_inputs` turns the file into :class:`RecordedInputs`: the session's settings, one
time-ordered *timeline* of everything that reached the live engine (each camera's frames, the
frames it measured but the recorder dropped, rangefinder readings, GPS fixes, stop events), and
per camera the commands applied at each frame (clicks, background references, the GPS cue, the
model background, engine states at recording gaps). :class:`snrmon.acquisition.replay.feeder.Feeder`
plays it into a :class:`snrmon.acquisition.engine.session_engine.SessionEngine`.

Format 1 files (no cues, states or reference images recorded) replay as before: cues are
projected from the recorded fixes, a reference is rebuilt from its recorded frames, and the
stops are detected again from the readings.
"""

from __future__ import annotations

import json
from collections import defaultdict
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from snrmon.acquisition.config import SessionConfig, session_config_from_dict
from snrmon.acquisition.record.analysis_file import read_results
from snrmon.acquisition.record.reader import SessionFile
from snrmon.acquisition.stops.detector import Stop, StopConfig

if TYPE_CHECKING:
    from snrmon.acquisition.calibrate.calibration import Calibration

# Timeline entry kinds, in the order entries of the same time are applied.
RANGE, FIX, STOP, FRAME = 0, 1, 2, 3

TIMELINE_DTYPE = np.dtype(
    [("t_ns", "<i8"), ("kind", "<i1"), ("camera", "<i2"), ("frame", "<i8"), ("row", "<i8")]
)
"""One entry: ``kind`` RANGE/FIX/STOP (``row`` indexes /rangefinder, /gps or the stop events) or
FRAME (``camera`` indexes ``cameras``; ``frame`` the frame in the file, -1 when the recorder
dropped it; ``row`` its measurement row, -1 when it was not measured)."""


@dataclass
class CameraInputs:
    """The commands recorded for one camera, in time order, each at the host time of the frame
    it took effect on: ``commands`` are (t_ns, kind, payload) with kind "roi_set",
    "roi_cleared", "background_reference", "reference_cleared" (applied before the first frame
    at or after t); ``model_inputs`` are (t_ns, kind, payload) changes of the model's inputs
    ("model_background": the measured sky; "model_psf": a PSF measured from the flight;
    "met_readings": the day's met readings, recorded once for the session; "model_noise": the
    operator's measured noise in place of the model's; applied after that frame); ``states``
    maps a frame counter to the engine state recorded before it. Format 1 files hold clicks and
    references only."""

    commands: list[tuple[int, str, dict]] = field(default_factory=list)
    model_inputs: list[tuple[int, str, dict]] = field(default_factory=list)
    states: dict[int, dict] = field(default_factory=dict)
    calibration: str | None = None


@dataclass
class RecordedInputs:
    """Everything a replay of one file applies (see the module docstring)."""

    config: SessionConfig
    track: bool
    stop_config: StopConfig | None
    version: int
    cameras: list[str]
    per_camera: dict[str, CameraInputs]
    stops: list[tuple[str, Stop]]  # (kind, stop) as recorded, in time order (format 2)
    final_rows: dict[tuple[int, str], dict]  # (stop, camera) -> recorded stop_summary payload
    timeline: np.ndarray  # TIMELINE_DTYPE, in time order


BEFORE_EVERYTHING_NS = -(2**62)
PSF_KEYS = ("band_um", "f_number", "pitch_um", "blur_px")  # what the model takes of a fit


def _psf_estimate(payload: dict) -> dict | None:
    """The fit the model takes from a ``psf_measured`` payload: its ``estimate`` (``snrmon
    psf``), or the payload itself where it is the estimate's own fields (``snrmon hil --out`` and
    the demo wrote them so before): None when it holds neither."""
    estimate = payload.get("estimate")
    if isinstance(estimate, dict):
        return estimate
    return payload if all(k in payload for k in PSF_KEYS) else None


"""The time of a model input that holds from the recording's first frame."""


def _settings(f: SessionFile) -> tuple[SessionConfig, bool, StopConfig | None]:
    cfg = f.config if isinstance(f.config, dict) else {}
    config = session_config_from_dict(cfg.get("session") or {})
    track = bool(cfg.get("track", True))
    stop = cfg.get("stop_detection")
    return config, track, (StopConfig(**stop) if stop else None)


def _stop_of(payload: dict) -> Stop | None:
    if "t_start_ns" not in payload:
        return None  # a format 1 event: the stop's times were not recorded
    return Stop(
        index=int(payload["stop"]),
        t_start_ns=int(payload["t_start_ns"]),
        t_end_ns=None if payload["t_end_ns"] is None else int(payload["t_end_ns"]),
        lrf_range_m=payload["lrf_range_m"],
        gps_range_m=payload["gps_range_m"],
        manual=bool(payload["manual"]),
        t_confirmed_ns=payload.get("t_confirmed_ns"),
    )


def recorded_inputs(f: SessionFile) -> RecordedInputs:
    """Read what a replay applies from an open session file (module docstring)."""
    config, track, stop_config = _settings(f)
    names = list(f.cameras)
    per: dict[str, CameraInputs] = {n: CameraInputs() for n in names}
    stops: list[tuple[str, Stop]] = []
    stop_times: list[int] = []
    final_rows: dict[tuple[int, str], dict] = {}
    measured_psf: dict[str, dict] = {}  # camera -> the latest PSF fitted after the flight
    for e in f.event_list():
        kind, cam, p, t = e["kind"], e["camera"], e["payload"], e["t_host_ns"]
        c = per.get(cam)
        if kind in ("stop_detected", "stop_ended", "stop_marked", "stop_known", "stop_open_at_end"):
            stop = _stop_of(p)
            if stop is not None:
                stops.append((kind, stop))
                stop_times.append(t)
        elif kind == "stop_summary" and c is not None:
            final_rows[(int(p["stop"]), cam)] = p
        elif kind == "met_readings":  # the session's, for every camera's model
            for each in per.values():
                each.model_inputs.append((t, kind, p))
        elif c is None:
            continue
        elif kind in ("roi_set", "roi_cleared", "background_reference", "reference_cleared"):
            c.commands.append((t, kind, p))
        elif kind in ("model_background", "model_psf", "model_noise"):
            c.model_inputs.append((t, kind, p))
        elif kind == "psf_measured" and (fit := _psf_estimate(p)) is not None:
            measured_psf[cam] = fit
        elif kind == "calibration" and "path" in p:
            c.calibration = p["path"]
    # Results kept beside the recording (snrmon psf without --write) count as if written in it.
    for r in read_results(f.path, created_utc=str(f.attrs.get("created_utc", ""))):
        p = r.get("payload") or {}
        fit = _psf_estimate(p) if r.get("kind") == "psf_measured" else None
        if fit is not None and r.get("camera") in per:
            measured_psf[r["camera"]] = fit
    for cam, estimate in measured_psf.items():
        # A PSF fitted after the flight is the camera's from the first frame on; a PSF the live
        # console adopted during the flight still takes over where it did.
        per[cam].model_inputs.insert(0, (BEFORE_EVERYTHING_NS, "model_psf", estimate))
    for name, rec in f.cameras.items():
        for row in rec.states:
            per[name].states[int(row["counter"])] = json.loads(bytes(row["state"]).decode())
    timeline = _timeline(f, names, stop_times)
    return RecordedInputs(
        config, track, stop_config, f.major_version, names, per, stops, final_rows, timeline
    )


def _timeline(f: SessionFile, names: list[str], stop_times: list[int]) -> np.ndarray:
    parts = []

    def part(t, kind, camera, frame, row) -> None:
        a = np.zeros(len(t), TIMELINE_DTYPE)
        a["t_ns"], a["kind"], a["camera"], a["frame"], a["row"] = t, kind, camera, frame, row
        parts.append(a)

    n = len(f.rangefinder)
    part(f.rangefinder["t_host_ns"], RANGE, -1, -1, np.arange(n))
    n = len(f.gps)
    part(f.gps["t_host_ns"], FIX, -1, -1, np.arange(n))
    part(np.asarray(stop_times, np.int64), STOP, -1, -1, np.arange(len(stop_times)))
    for k, name in enumerate(names):
        cam = f.cameras[name]
        meas = cam.measurements
        index = meas["frame_index"]
        # A row names its frame by index; rows past what the file holds (a crash) lost theirs.
        frame_of_row = np.where(index < cam.n_frames, index, -1)
        row_of_frame = np.full(cam.n_frames, -1, np.int64)
        present = frame_of_row >= 0
        row_of_frame[frame_of_row[present]] = np.flatnonzero(present)
        part(cam.t_host_ns, FRAME, k, np.arange(cam.n_frames), row_of_frame)
        missing = np.flatnonzero(~present)
        part(meas["t_host_ns"][missing], FRAME, k, -1, missing)
    timeline = np.concatenate(parts) if parts else np.zeros(0, TIMELINE_DTYPE)
    # Time order; at equal times, readings before frames (a reading is applied when it arrives).
    order = np.lexsort((timeline["kind"], timeline["t_ns"]))
    return timeline[order]


def frames_between(cam, first_counter: int, last_counter: int) -> tuple[np.ndarray, np.ndarray]:
    """The recorded frames (and their counters) whose camera counters run from ``first`` to
    ``last`` (inclusive): a format 1 background reference is rebuilt from them."""
    idx = np.flatnonzero((cam.counter >= first_counter) & (cam.counter <= last_counter))
    if idx.size < 2:
        raise ValueError(
            f"{cam.name}: the background reference frames {first_counter}..{last_counter} are "
            "not in the recording, so the corrected measurement cannot be replayed"
        )
    lo, hi = int(idx[0]), int(idx[-1]) + 1
    return cam.frames[lo:hi], cam.counter[lo:hi]


def recording_drops(f: SessionFile) -> dict[str, dict[str, int]]:
    """Frames each camera lost, by reason, as the recorder counted them (its summary; for a
    file whose writer died, what the file shows: measured frames whose pixels are missing)."""
    out: dict[str, dict[str, int]] = defaultdict(dict)
    if f.summary is not None:
        for cam, reasons in (f.summary.get("dropped") or {}).items():
            out[cam] = {str(k): int(v) for k, v in reasons.items()}
        return {c: dict(out.get(c, {})) for c in f.cameras}
    for name, cam in f.cameras.items():
        lost = int(np.count_nonzero(cam.measurements["frame_index"] < 0))
        out[name] = {"not_in_file": lost} if lost else {}
    return dict(out)


def recorded_calibration(
    f: SessionFile, camera: str, path: str | None = None, sensor=None
) -> tuple[Calibration, str] | None:
    """``(calibration, where it came from)`` for ``camera``'s frames: ``path`` if given (a
    re-analysis with another calibration), else the one the live measurement ran with: kept in
    the file (format 2.3 on), or, in an earlier file, loaded from the path its ``calibration``
    event names; None without one. With ``sensor`` it is checked to be that camera's; it always
    fits the recorded frames."""
    from snrmon.acquisition.calibrate.calibration import check_matches_sensor
    from snrmon.acquisition.calibrate.calibration_file import (
        calibration_from_record,
        load_calibration,
    )

    frames = f.cameras[camera].frames
    shape = (int(frames.shape[1]), int(frames.shape[2]))
    recorded_path = _recorded_calibration_path(f, camera)
    # the recorded calibration asked for by its path (as a campaign passes the recorded
    # settings) is the one the file keeps, whether or not that path still exists
    kept = f.calibration_record(camera) if path in (None, recorded_path) else None
    if kept is None:
        path = path or recorded_path
        if path is None:
            return None
        return load_calibration(path, sensor, frame_shape=shape), str(path)
    source = f"{f.path.name}: {camera}'s calibration"
    cal = calibration_from_record(*kept, source=source)
    if sensor is not None:
        check_matches_sensor(cal, sensor, source=source)
    if cal.shape != shape:
        raise ValueError(f"{source} is for {cal.shape[1]}x{cal.shape[0]} frames, not the file's")
    return cal, source


def _recorded_calibration_path(f: SessionFile, camera: str) -> str | None:
    """The calibration file a pre-2.3 recording's ``calibration`` event names, or None."""
    path = None
    for e in f.event_list():
        if e["kind"] == "calibration" and e["camera"] == camera and "path" in e["payload"]:
            path = e["payload"]["path"]
    return path
