"""Does each configured device answer? Cameras at their frame rate, the rangefinder, the GPS
with a fix (and how old it is), and the GPS clock against the host clock.

Every device of the session config is opened through its ordinary driver at once, watched for
``wait_s`` until it answers and then for ``window_s`` more, and closed. The numbers:

* camera: frames received over the window and the rate they came at, against the rate the camera
  negotiated (or its sensor preset's); the format it delivers against the sensor's size.
* rangefinder: its first reading (a shot with no target still proves it answers).
* GPS: whether a fix came, its satellites and HDOP, the age of the last fix when the window
  closed, and the median of (receiver UTC - host UTC at receipt) over the fixes: recordings map
  the common monotonic clock to UTC with the host clock, so a host clock off by seconds puts
  every timestamp off by as much. Serial transfer delays a sentence by a few tens of ms, well
  inside :data:`CLOCK_TOLERANCE_S`.
"""

from __future__ import annotations

import statistics
import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from snrmon.doctor import FAIL, PASS, Check

if TYPE_CHECKING:
    from snrmon.drivers.config import DeviceSettings

SAMPLE_FRAMES = 4  # each camera's first frames, kept to measure how they compress
MIN_FPS_FRACTION = 0.95  # a camera below 95 % of its rate is dropping frames somewhere
MAX_FIX_AGE_S = 2.0  # a 1-10 Hz receiver's last fix is never this old while it works
CLOCK_TOLERANCE_S = 1.0


@dataclass
class _Watch:
    kind: str  # camera | lrf | gps
    name: str
    device: Any  # None: its driver could not be made (``error`` says why, ``fix`` what to do)
    readings: list = field(default_factory=list)  # (t_host_ns, reading or counter)
    first: threading.Event = field(default_factory=threading.Event)
    error: str = ""
    fix: str = ""
    samples: list = field(default_factory=list)  # a camera's first frames' pixels (copies)

    def take(self, reading) -> None:
        item = reading.counter if self.kind == "camera" else reading
        if self.kind == "camera" and len(self.samples) < SAMPLE_FRAMES:
            self.samples.append(reading.pixels.copy())  # the ring slot is reused
        self.readings.append((time.monotonic_ns(), item))
        self.first.set()


def _open(config) -> list[_Watch]:
    from snrmon.acquisition.config import camera_device

    watches = []
    for cam in config.cameras:
        watches.append(_made("camera", cam.name, lambda cam=cam: camera_device(cam)))
    for kind in ("lrf", "gps"):
        settings = getattr(config, kind)
        if settings is not None:
            watches.append(_made(kind, kind, lambda s=settings, k=kind: s.device(k)))
    for w in watches:
        if w.device is not None:
            w.device.subscribe(w.take)
            w.device.open()
    return watches


def _made(kind: str, name: str, make) -> _Watch:
    """The watch of one device; a driver that cannot be made (its backend is not installed:
    Aravis without PyGObject, a MAVLink GPS without pymavlink) is a failed check with the
    install hint as its fix, and the other checks go on."""
    try:
        return _Watch(kind, name, make())
    except (ImportError, OSError, ValueError) as exc:
        from snrmon.drivers.camera.aravis import INSTALL_HINT

        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if text.startswith(INSTALL_HINT):
            why = text.removeprefix(INSTALL_HINT).strip(" ()")
            return _Watch(
                kind, name, None, error=f"Aravis is not available ({why})", fix=INSTALL_HINT
            )
        return _Watch(kind, name, None, error=f"no driver: {text}", fix=text)


def _watch(watches: list[_Watch], wait_s: float, window_s: float) -> None:
    """Until every device answered (or ``wait_s``), then ``window_s`` more."""
    deadline = time.monotonic() + wait_s
    for w in watches:
        w.first.wait(max(0.0, deadline - time.monotonic()))
    end = time.monotonic() + window_s
    while time.monotonic() < end:
        time.sleep(min(0.1, max(0.0, end - time.monotonic())))  # a measurement window


def check_devices(
    config, *, wait_s: float = 5.0, window_s: float = 2.0, samples: dict | None = None
) -> tuple[list[Check], dict]:
    """One check per camera and rangefinder, two for the GPS (fix, clock); and the cameras'
    negotiated formats ({name: CameraFormat}) for the disk checks. ``samples``, when given,
    gets each answering camera's first frames ({name: [pixels, ...]}), for the disk checks'
    compression ratio."""
    watches = _open(config)
    opened = [w for w in watches if w.device is not None]
    try:
        _watch(opened, wait_s, window_s)
    finally:
        for w in opened:
            w.error = w.device.status().last_error
            w.device.close()
    checks: list[Check] = []
    formats = {}
    for w in watches:
        if w.device is None:
            label = f"camera:{w.name}" if w.kind == "camera" else w.kind
            if w.kind == "gps":
                label = "gps-fix"
            where = f"[cameras.{w.name}]" if w.kind == "camera" else f"[{w.kind}]"
            checks.append(Check(label, FAIL, f"{where}: {w.error}", w.fix))
        elif w.kind == "camera":
            cam = next(c for c in config.cameras if c.name == w.name)
            checks.append(_camera(w, cam, wait_s))
            if w.device.format is not None:
                formats[w.name] = w.device.format
            if samples is not None and w.samples:
                samples[w.name] = w.samples
        elif w.kind == "lrf":
            checks.append(_lrf(w, config.lrf, wait_s))
        else:
            checks += _gps(w, wait_s)
    return checks, formats


def _expected_fps(w: _Watch, cam) -> float | None:
    fmt = w.device.format
    if fmt is not None and fmt.fps:
        return float(fmt.fps)
    try:
        from snrmon.model.presets import load_sensor

        return float(load_sensor(cam.sensor).fps)
    except (ValueError, OSError):
        return None


def _camera(w: _Watch, cam, wait_s: float) -> Check:
    name = f"camera:{w.name}"
    where = f"[cameras.{w.name}] {cam.source} {cam.address!r}"
    if len(w.readings) < 2:
        return Check(
            name,
            FAIL,
            f"{where}: no frames in {wait_s:g} s" + (f" ({w.error})" if w.error else ""),
            "check the camera's power and cable, and its address with `snrmon devices`; "
            "a shared-memory camera needs its writer running",
        )
    (t0, c0), (t1, c1) = w.readings[0], w.readings[-1]
    fps = (len(w.readings) - 1) / ((t1 - t0) / 1e9)
    lost = max(0, (c1 - c0 + 1) - len(w.readings))
    expected = _expected_fps(w, cam)
    fmt = w.device.format
    data = {
        "fps": fps,
        "expected_fps": expected,
        "frames": len(w.readings),
        "lost": lost,
        "format": str(fmt) if fmt else None,
    }
    shown = f"{where}: {len(w.readings)} frames at {fps:.1f} fps"
    if fmt is not None:
        shown += f", {fmt.width}x{fmt.height} {fmt.pixel_format}"
    if expected is not None and fps < MIN_FPS_FRACTION * expected:
        return Check(
            name,
            FAIL,
            f"{shown}: below its {expected:g} fps ({lost} lost)",
            "check the link speed (USB 3 port, GigE with jumbo frames: `snrmon devices`),"
            " the camera's trigger and exposure, and the CPU load",
            data=data,
        )
    size, sensor_fps = _sensor_format(cam)
    if fmt is not None and size is not None and size != (fmt.width, fmt.height):
        return Check(
            name,
            FAIL,
            f"{shown}; but sensor {cam.sensor!r} is {size[0]}x{size[1]}",
            f"set [cameras.{w.name}] sensor to this camera's sensor TOML (the model "
            "needs its true format)",
            data=data,
        )
    if fmt is not None and fmt.fps and sensor_fps and abs(fmt.fps / sensor_fps - 1) > 0.01:
        return Check(
            name,
            FAIL,
            f"{shown}; the camera runs at {fmt.fps:g} fps but sensor "
            f"{cam.sensor!r} says {sensor_fps:g}",
            "set the camera's frame rate to the "
            "sensor's (the model's integration and noise assume it), or use a sensor "
            "TOML for this rate",
            data=data,
        )
    rate = f" of {expected:g}" if expected is not None else ""
    return Check(name, PASS, f"{shown} ({fps:.1f}{rate} fps)", data=data)


def _sensor_format(cam) -> tuple[tuple[int, int] | None, float | None]:
    """(width, height) the config or the sensor preset says, and the preset's rate."""
    try:
        from snrmon.model.presets import load_sensor

        s = load_sensor(cam.sensor)
    except (ValueError, OSError):
        s = None
    w = cam.width_px or (s.width_px if s else None)
    h = cam.height_px or (s.height_px if s else None)
    return ((w, h) if w and h else None), (s.fps if s else None)


def _lrf(w: _Watch, settings: DeviceSettings, wait_s: float) -> Check:
    port = settings.port
    if not w.readings:
        fired = settings.protocol == "trupulse"
        fix = (
            "fire the TruPulse at a target while snrmon doctor waits (it speaks only when fired); "
            if fired
            else ""
        ) + "check its power, [lrf] port and baud"
        return Check(
            "lrf",
            FAIL,
            f"rangefinder on {port}: no reading in {wait_s:g} s"
            + (f" ({w.error})" if w.error else ""),
            fix,
        )
    r = w.readings[-1][1]
    rng = f"{r.range_m:.1f} m" if r.range_m is not None else "no range"
    return Check(
        "lrf",
        PASS,
        f"rangefinder on {port} answers: {rng} ({r.status})",
        data={"readings": len(w.readings), "range_m": r.range_m},
    )


def _gps(w: _Watch, wait_s: float) -> list[Check]:
    fixes = [(t, f) for t, f in w.readings if f.has_fix]
    if not w.readings:
        no_data = Check(
            "gps-fix",
            FAIL,
            f"GPS: no sentence in {wait_s:g} s" + (f" ({w.error})" if w.error else ""),
            "check the receiver's power, [gps] port and baud",
        )
        return [no_data, Check("gps-clock", FAIL, "GPS: no time to compare", no_data.fix)]
    if not fixes:
        fix = "give the antenna open sky and wait for the first fix (minutes after a cold start)"
        return [
            Check(
                "gps-fix",
                FAIL,
                f"GPS answers but has no fix ({len(w.readings)} sentences, quality 0)",
                fix,
            ),
            Check("gps-clock", FAIL, "GPS: no fix, no time to compare", fix),
        ]
    now = time.monotonic_ns()
    t_last, last = fixes[-1]
    age_s = (now - t_last) / 1e9
    data = {
        "sats": last.sats,
        "hdop": last.hdop,
        "quality": last.fix_quality,
        "age_s": age_s,
        "lat_deg": last.lat_deg,
        "lon_deg": last.lon_deg,
    }
    shown = (
        f"GPS fix: quality {last.fix_quality}, {last.sats} satellites, HDOP "
        f"{last.hdop}, last fix {age_s:.2f} s old"
    )
    if age_s > MAX_FIX_AGE_S:
        fix_check = Check(
            "gps-fix",
            FAIL,
            shown,
            "the receiver stopped sending fixes: check the cable and its output rate",
            data=data,
        )
    else:
        fix_check = Check("gps-fix", PASS, shown, data=data)
    return [fix_check, _clock(fixes, now)]


def _clock(fixes: list, now_ns: int) -> Check:
    wall_now = time.time()
    offsets = [
        (f.utc.timestamp() - (wall_now - (now_ns - t) / 1e9)) for t, f in fixes if f.utc is not None
    ]
    if not offsets:
        return Check(
            "gps-clock",
            FAIL,
            "the receiver gives no valid date/time (a firmware "
            "with the 2019 week-rollover bug sends impossible dates)",
            "update the receiver's firmware; until then positions are used and "
            "times come from the host clock alone",
        )
    offset = statistics.median(offsets)
    data = {"offset_s": offset, "fixes": len(offsets)}
    shown = f"GPS UTC - host UTC = {offset:+.3f} s (median of {len(offsets)} fixes)"
    if abs(offset) > CLOCK_TOLERANCE_S:
        return Check(
            "gps-clock",
            FAIL,
            shown,
            "set the host clock from the GPS (chrony with "
            "gpsd's SHM refclock, or `sudo date -u -s` to the receiver's time): "
            "recordings stamp UTC with the host clock",
            data=data,
        )
    return Check("gps-clock", PASS, f"{shown}, within {CLOCK_TOLERANCE_S:g} s", data=data)
