"""Replay of a recorded session through the same measurement (issue 6).

Frames are read from the session file in order and measured by the same
:class:`acquisition.engine.frame_measurer.FrameMeasurer` as the live pipeline, with the recorded
``roi_set`` events applied at the frame they took effect on, so the per-frame SNR equals the
recorded one exactly when the recording holds the track from its click. The recorded rangefinder
and GPS streams drive the same stop detector, and the same stop table is rebuilt.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from acquisition.config import session_config_from_dict
from acquisition.engine.frame_correction import FrameCorrector
from acquisition.engine.frame_measurer import FrameMeasurer, crop_half_px
from acquisition.geo.projection import Site, slant_range_m
from acquisition.measure.peak_snr import PeakSnr, PeakSnrConfig, flags_from_bits
from acquisition.record.frame_access import FrameCrops
from acquisition.record.reader import SessionFile, open_session
from acquisition.stops.detector import StopConfig, StopDetector
from acquisition.stops.table import Predictor, StopRow, StopTable


@dataclass
class CameraReplay:
    name: str
    n_frames: int = 0
    results: list[PeakSnr] = field(default_factory=list)
    t_host_ns: list[int] = field(default_factory=list)
    identical: int = 0
    compared: int = 0


@dataclass
class ReplayResult:
    cameras: dict[str, CameraReplay]
    stops: list[StopRow]
    seconds: float
    recording_seconds: float

    @property
    def realtime_factor(self) -> float:
        return self.recording_seconds / self.seconds if self.seconds > 0 else math.inf


def frames_between(cam, first_counter: int, last_counter: int) -> tuple[np.ndarray, np.ndarray]:
    """The recorded frames (and their counters) whose camera counters run from ``first`` to
    ``last`` (inclusive)."""
    idx = np.flatnonzero((cam.counter >= first_counter) & (cam.counter <= last_counter))
    if idx.size < 2:
        raise ValueError(
            f"{cam.name}: the background reference frames {first_counter}..{last_counter} are "
            "not in the recording, so the corrected measurement cannot be replayed"
        )
    lo, hi = int(idx[0]), int(idx[-1]) + 1
    return cam.frames[lo:hi], cam.counter[lo:hi]


def _same(a: float, b: float) -> bool:
    return (a == b) or (math.isnan(a) and math.isnan(b))


def _settings(f: SessionFile) -> tuple[PeakSnrConfig, int, Site | None]:
    raw = f.config.get("session") if isinstance(f.config, dict) else None
    if raw:
        cfg = session_config_from_dict(raw)
        return cfg.measurement, cfg.window, cfg.site
    return PeakSnrConfig(), 100, None


@dataclass
class RecordedEvents:
    """The operator's recorded events per camera, in time order: ROI clicks (t_ns, x, y),
    background references (t_ns, first counter, last counter) and calibration file paths."""

    rois: dict[str, list[tuple[int, int, int]]] = field(default_factory=dict)
    references: dict[str, list[tuple[int, int, int]]] = field(default_factory=dict)
    calibrations: dict[str, str] = field(default_factory=dict)


def recorded_events(f: SessionFile) -> RecordedEvents:
    """The events a replay applies, parsed once from the file (the replay and the console's
    replay player share this, so both apply the same events at the same frames)."""
    out = RecordedEvents()
    for e in f.event_list():
        if e["camera"] not in f.cameras:
            continue
        p = e["payload"]
        if e["kind"] == "roi_set":
            out.rois.setdefault(e["camera"], []).append((e["t_host_ns"], int(p["x"]), int(p["y"])))
        elif e["kind"] == "calibration" and "path" in p:
            out.calibrations[e["camera"]] = p["path"]
        elif e["kind"] == "background_reference":
            out.references.setdefault(e["camera"], []).append(
                (e["t_host_ns"], int(p["first_counter"]), int(p["last_counter"]))
            )
    for lists in (out.rois, out.references):
        for k in lists:
            lists[k].sort()
    return out


def recorded_track(f: SessionFile) -> bool:
    """Whether the recording's measurement followed the drone (tracking on) or stayed put."""
    return bool(f.config.get("track", True)) if isinstance(f.config, dict) else True


def recorded_stop_detector(f: SessionFile) -> StopDetector:
    """A stop detector with the recording's own settings (the defaults when it has none)."""
    stop_settings = f.config.get("stop_detection") if isinstance(f.config, dict) else None
    return StopDetector(StopConfig(**stop_settings) if stop_settings else None)


def range_readings(f: SessionFile, site: Site | None) -> list[tuple[int, float, str]]:
    """The recorded ranges in time order as (t_host_ns, range_m, source): every valid
    rangefinder reading ("lrf") and, with a site, every GPS fix's slant range ("gps")."""
    readings: list[tuple[int, float, str]] = [
        (int(r["t_host_ns"]), float(r["range_m"]), "lrf")
        for r in f.rangefinder
        if r["status"] == b"ok" and np.isfinite(r["range_m"]) and r["range_m"] > 0
    ]
    if site is not None:
        readings += [
            (int(g["t_host_ns"]), slant_range_m(site, g["lat_deg"], g["lon_deg"], g["alt_msl_m"]),
             "gps")
            for g in f.gps
            if g["fix_quality"] > 0 and np.isfinite(g["alt_msl_m"])
        ]  # fmt: skip
    return sorted(readings)


def recorded_calibration(f: SessionFile, name: str, events: RecordedEvents):
    """The calibration the live measurement of ``name`` ran with (loaded again from its
    recorded path), or None."""
    if name not in events.calibrations:
        return None
    from acquisition.calibrate.calibration_file import load_calibration

    shape = tuple(f.cameras[name].frames.shape[1:])
    return load_calibration(events.calibrations[name], frame_shape=shape)


def camera_corrector(
    f: SessionFile, name: str, half_px: int, events: RecordedEvents
) -> FrameCorrector:
    """The frame correction the live measurement ran with: the recording keeps raw frames, so
    a recorded calibration is loaded and applied again (references are set as they come)."""
    corrector = FrameCorrector(f.cameras[name].frames.shape[1:], half_px)
    corrector.calibration = recorded_calibration(f, name, events)
    return corrector


def replay_session(
    path: str | Path,
    *,
    speed: float | None = None,
    fast: bool = False,
    track: bool | None = None,
    predictor: Predictor | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> ReplayResult:
    """Measure every recorded frame again; ``speed`` paces to the recorded times (1 = real
    time), None runs as fast as the disk allows.

    ``fast`` reads from the file only a square around the track (:func:`crop_half_px`) and
    pastes it into a full-size buffer at its place, so the measurement code and its results are
    unchanged (it never reads outside that square) while the disk reads a few kB per frame.
    ``track`` None follows the recording (tracking on or off as it was live).
    """
    with open_session(path) as f:
        config, window, site = _settings(f)
        if track is None:
            track = recorded_track(f)
        parsed = recorded_events(f)
        rois, references = parsed.rois, parsed.references
        detector = recorded_stop_detector(f)
        # Both range streams in time order: a stop's GPS range is the median of the fixes
        # that arrive while it is open.
        for t, rng, source in range_readings(f, site):
            detector.add_range(t, rng, source)
        table = StopTable(detector, list(f.cameras), history_frames=10**7, predictor=predictor)
        out: dict[str, CameraReplay] = {}
        t_start = time.monotonic()
        total = sum(c.n_frames for c in f.cameras.values())
        done = 0
        span_ns = 0
        for name, cam in f.cameras.items():
            rep = CameraReplay(name, cam.n_frames)
            out[name] = rep
            measurer = FrameMeasurer(config, window=window, track=track)
            events = sorted(rois.get(name, []))
            half = crop_half_px(config, measurer.tracker_config)
            corrector = camera_corrector(f, name, half, parsed)
            refs = sorted(references.get(name, []))
            recorded = {int(m["frame_index"]): m for m in cam.measurements if m["frame_index"] >= 0}
            if cam.n_frames:
                span_ns = max(span_ns, int(cam.t_host_ns[-1] - cam.t_host_ns[0]))
            t0_rec = int(cam.t_host_ns[0]) if cam.n_frames else 0
            wall0 = time.monotonic()
            shape = cam.frames.shape[1:]
            buffer = np.zeros(shape, cam.frames.dtype) if fast else None
            crops = FrameCrops(cam.frames) if fast else None
            for i in range(cam.n_frames):
                t = int(cam.t_host_ns[i])
                while refs and refs[0][0] <= t:
                    _, first, last = refs.pop(0)
                    corrector.set_reference(*frames_between(cam, first, last))
                while events and events[0][0] <= t:
                    _, x, y = events.pop(0)
                    measurer.set_roi(x, y)
                if speed is not None:
                    due = wall0 + (t - t0_rec) / 1e9 / speed
                    delay = due - time.monotonic()
                    if delay > 0:
                        time.sleep(delay)  # pacing to the recorded clock, not synchronisation
                if buffer is not None and measurer.roi is not None:
                    x, y = measurer.read_xy
                    y0, y1 = max(y - half, 0), min(y + half + 1, shape[0])
                    x0, x1 = max(x - half, 0), min(x + half + 1, shape[1])
                    buffer[y0:y1, x0:x1] = crops.crop(i, y0, y1, x0, x1)
                    if config.background is not None:  # the clear-sky rectangle too
                        bx0, by0, bx1, by1 = config.background
                        buffer[by0 : by1 + 1, bx0 : bx1 + 1] = crops.crop(
                            i, by0, by1 + 1, bx0, bx1 + 1
                        )
                    pixels = buffer
                elif measurer.roi is None:
                    pixels = None  # nothing to measure: do not read the frame at all
                else:
                    pixels = cam.frames[i]
                if pixels is not None:
                    pixels = corrector.apply(pixels, measurer.read_xy)
                fr = measurer.measure(pixels) if pixels is not None else None
                done += 1
                if progress is not None and done % 50 == 0:
                    progress(done, total)
                if fr is None:
                    continue
                rep.results.append(fr.result)
                rep.t_host_ns.append(t)
                table.add(name, t, fr.result)
                rec = recorded.get(i)
                if rec is not None:
                    rep.compared += 1
                    same = (
                        _same(float(rec["snr"]), fr.result.snr)
                        and int(rec["peak_x"]) == fr.result.peak_x
                        and int(rec["peak_y"]) == fr.result.peak_y
                        and flags_from_bits(int(rec["flags"])) == fr.result.flags
                    )
                    rep.identical += int(same)
        seconds = time.monotonic() - t_start
        return ReplayResult(out, table.rows(), seconds, span_ns / 1e9)
