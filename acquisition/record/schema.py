"""The layout of a snrmon session file (HDF5): names, dtypes and units, shared by writer and reader.

Documented for users in ``docs/session-format.md``; bump ``FORMAT_VERSION`` whenever a dataset or
field changes meaning. Strings are fixed-length, NUL-padded UTF-8 bytes (MATLAB ``h5read`` returns
them as char arrays); missing integers are -1 and missing floats NaN, as stated per field.
"""

from __future__ import annotations

import numpy as np

# text_field, text_value: the file's text encoding, used through this module
from snrmon.acquisition.columns import (  # noqa: F401
    Column,
    columns_of,
    defaults_of,
    text_field,
    text_value,
)
from snrmon.acquisition.measure.peak_snr import (  # noqa: F401  (FLAG_NAMES: the bits of "flags")
    FLAG_NAMES,
    PeakSnr,
)

FORMAT = "snrmon-session"
FORMAT_VERSION = "2.4"
"""2.4: UTC comes from one monotone map of the host clock (docs/session-format.md, "Time"):
``/clock`` rows carry ``rate``, ``slew_until_ns`` and ``residual_ns``; a row is a slew from its
start, never a step, so ``utc_ns`` and ``time`` increase with ``t_host_ns``. Earlier files' rows
are references at rate 1 (read as before).
2.4 also: /cameras/<name>/measurements is a group of one 1-D dataset per field (a table of named
columns: xarray opens it as such, MATLAB reads a column with h5read), each with CF units and a
long_name, with its ``measurement`` dimension in the group; the fields and their meanings are
those of 2.3's compound rows. The root carries ``Conventions = "CF-1.10"``. A 2.3 file (compound
measurements) is read as before.

2.3: the radiometric calibration a camera was measured with is in the file
(/cameras/<name>/calibration: its per-pixel maps and, in the group's ``metadata_json``, the
calibration file's metadata), so a replay, ``characterize``, ``psf`` and ``noise`` apply the same
calibration without the file it was loaded from. Earlier files name the calibration file in
their ``calibration`` event, as before.

2.2: self-describing: every dataset carries ``units`` and ``long_name`` attributes (CF style),
and dimension scales name every axis (``time``, a new per-frame coordinate of the frame's UTC,
with ``row`` and ``col`` for the frame cubes; pure dimensions ``measurement``, ``state``,
``reference`` and one per stream), so netCDF readers (xarray with h5netcdf) see named dimensions
and coordinates. Nothing existing changed meaning: 2.0 and 2.1 files are read as before.

2.1: frames dropped before measurement (the camera's counter skips) are told to the tracker
(docs/tracking.md, "Frame gaps"), and the engine states hold the last counter; a 2.0 file is
replayed with gaps not told, as it was recorded.

2.0: per-frame background method and target extent, track state, window, cue,
running statistics and range in /cameras/<name>/measurements; engine states at recording gaps
(/cameras/<name>/states); background reference images (/cameras/<name>/references); stop events
carry the stop's times. A 1.x file is still read (the new fields are missing there) and replayed
as before."""

CAMERAS = "cameras"
FRAMES = "frames"
FRAME_COLUMNS = ("counter", "t_host_ns", "t_device_ns", "utc_ns")
TIME = "time"  # per-frame coordinate: the frame's UTC (the same values as utc_ns), CF time units
ROW = "row"
COL = "col"
MEASUREMENTS = "measurements"
STATES = "states"
REFERENCES = "references"
CALIBRATION = "calibration"  # group: the calibration's per-pixel maps (format 2.3 on)
CALIBRATION_MAPS: dict[str, str] = {
    "responsivity": "float32",
    "offset_dn": "float32",
    "bad": "uint8",
    "fit_rms_dn": "float32",
    "temporal_noise_dn": "float32",
}
"""The calibration maps a session file holds, (H, W) each, and their dtypes."""
RANGEFINDER = "rangefinder"
GPS = "gps"
EVENTS = "events"
CLOCK = "clock"
CONFIG = "config"

RAW_BYTES = 256
GPS_RAW_BYTES = 512
PAYLOAD_BYTES = 4096
NAME_BYTES = 32
STATE_BYTES = 65536
STATE_TEXT_BYTES = 16

MEASUREMENT_BEFORE: tuple[Column, ...] = (
    Column(
        "index into frames (-1: frame not in the file)",
        cf_units="1",
        dtype="<i8",
        name="frame_index",
    ),
    Column("camera frame counter", cf_units="1", dtype="<i8", name="counter"),
    Column("ns, host monotonic clock", units="ns", cf_units="ns", dtype="<i8", name="t_host_ns"),
)
"""The frame's columns of a measurement row, before its Eq. (4) result."""
MEASUREMENT_AFTER: tuple[Column, ...] = (
    Column(
        "fixed | tracking | lost | gps_cued | ... (the tracker's state after the frame)",
        dtype=f"S{STATE_TEXT_BYTES}",
        name="track_state",
    ),
    Column(
        "px, column of the search window's centre after the frame",
        units="px",
        cf_units="1",
        dtype="<i4",
        name="window_x",
    ),
    Column(
        "px, row of the search window's centre after the frame",
        units="px",
        cf_units="1",
        dtype="<i4",
        name="window_y",
    ),
    Column(
        "px, column of the GPS cue applied before this frame (NaN: none)",
        units="px",
        cf_units="1",
        dtype="<f8",
        name="cue_x",
    ),
    Column(
        "px, row of the GPS cue applied before this frame (NaN: none)",
        units="px",
        cf_units="1",
        dtype="<f8",
        name="cue_y",
    ),
    Column(
        "1, running mean of the last (100) valid per-frame SNRs after this frame",
        units="1",
        cf_units="1",
        dtype="<f8",
        name="snr_mean",
    ),
    Column(
        "1, their sample std (ddof=1; NaN with fewer than 2)",
        units="1",
        cf_units="1",
        dtype="<f8",
        name="snr_std",
    ),
    Column("values in the running window", units="frames", cf_units="1", dtype="<i4", name="snr_n"),
    Column(
        "m, range at the frame's time (interpolated; NaN: none; raw: /rangefinder)",
        units="m",
        cf_units="m",
        dtype="<f8",
        name="range_m",
    ),
    Column("lrf | gps | empty", dtype="S8", name="range_source"),
)
"""The engine's columns of a measurement row after its Eq. (4) result: the track, the running
statistics and the range."""
PEAK_SNR_COLUMNS: tuple[Column, ...] = columns_of(PeakSnr)
"""The Eq. (4) result's columns: the fields :class:`PeakSnr` declares."""
MEASUREMENT_COLUMNS: tuple[Column, ...] = (
    *MEASUREMENT_BEFORE,
    *PEAK_SNR_COLUMNS,
    *MEASUREMENT_AFTER,
)
"""Every column of /cameras/<name>/measurements, in their order."""
MEASUREMENT_DTYPE = np.dtype([(c.name, c.dtype) for c in MEASUREMENT_COLUMNS])
MEASUREMENT_FIELDS_V1 = (
    "frame_index",
    "counter",
    "t_host_ns",
    "peak_x",
    "peak_y",
    "peak",
    "bg_mean",
    "bg_std",
    "snr",
    "flags",
)
MEASUREMENT_UNITS = {c.name: c.meaning for c in MEASUREMENT_COLUMNS}
MEASUREMENT_CF: dict[str, tuple[str | None, str]] = {
    c.name: (c.cf_units, f"{c.name}: {c.meaning}") for c in MEASUREMENT_COLUMNS
}
"""CF ``units`` (None: a text or a flag field, CF gives it none) and ``long_name`` of each
measurement column (format 2.4): DN and pixel positions are counts, ``1``."""
MEASUREMENT_DEFAULTS: dict[str, object] = {
    c.name: c.file_value(defaults_of(PeakSnr)[c.name])
    for c in PEAK_SNR_COLUMNS
    if c.name in defaults_of(PeakSnr)
}
"""What a column a file lacks (written before the column existed) reads as: the field's
default, as the file holds it."""

STATE_DTYPE = np.dtype([("counter", "<i8"), ("t_host_ns", "<i8"), ("state", f"S{STATE_BYTES}")])
STATE_UNITS = {
    "counter": "camera frame counter of the first recorded frame after a gap",
    "t_host_ns": "ns, host monotonic clock of that frame",
    "state": "JSON object, UTF-8: the measurement state before that frame (replay restores it)",
}

RANGE_DTYPE = np.dtype(
    [
        ("t_host_ns", "<i8"),
        ("utc_ns", "<i8"),
        ("range_m", "<f8"),
        ("status", f"S{NAME_BYTES}"),
        ("horizontal_m", "<f8"),
        ("azimuth_deg", "<f8"),
        ("inclination_deg", "<f8"),
        ("quality", "<i4"),
        ("raw", f"S{RAW_BYTES}"),
    ]
)
RANGE_UNITS = {
    "t_host_ns": "ns, host monotonic clock at receipt",
    "utc_ns": "ns since 1970-01-01 UTC (host clock mapped through /clock)",
    "range_m": "m, slant range (NaN: no range)",
    "status": "ok | no_target | error",
    "horizontal_m": "m (NaN: not given)",
    "azimuth_deg": "deg clockwise from north (NaN: not given)",
    "inclination_deg": "deg above horizon (NaN: not given)",
    "quality": "device-specific (-1: not given)",
    "raw": "line as received, UTF-8",
}

GPS_DTYPE = np.dtype(
    [
        ("t_host_ns", "<i8"),
        ("utc_ns", "<i8"),
        ("fix_utc_ns", "<i8"),
        ("lat_deg", "<f8"),
        ("lon_deg", "<f8"),
        ("alt_msl_m", "<f8"),
        ("alt_ellipsoid_m", "<f8"),
        ("fix_quality", "<i2"),
        ("sats", "<i2"),
        ("hdop", "<f8"),
        ("raw", f"S{GPS_RAW_BYTES}"),
    ]
)
GPS_UNITS = {
    "t_host_ns": "ns, host monotonic clock at receipt",
    "utc_ns": "ns since 1970-01-01 UTC (host clock mapped through /clock)",
    "fix_utc_ns": "ns since 1970-01-01 UTC from the receiver (-1: no date yet)",
    "lat_deg": "deg WGS-84, north positive (NaN: none)",
    "lon_deg": "deg WGS-84, east positive (NaN: none)",
    "alt_msl_m": "m above mean sea level (NaN: none)",
    "alt_ellipsoid_m": "m above WGS-84 ellipsoid (NaN: none)",
    "fix_quality": "GGA quality (0 none, 1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float)",
    "sats": "satellites used (-1: not given)",
    "hdop": "1 (NaN: not given)",
    "raw": "sentence(s) as received, UTF-8",
}

EVENT_DTYPE = np.dtype(
    [
        ("t_host_ns", "<i8"),
        ("utc_ns", "<i8"),
        ("kind", f"S{NAME_BYTES}"),
        ("camera", f"S{NAME_BYTES}"),
        ("payload", f"S{PAYLOAD_BYTES}"),
    ]
)
EVENT_UNITS = {
    "t_host_ns": "ns, host monotonic clock",
    "utc_ns": "ns since 1970-01-01 UTC (host clock mapped through /clock)",
    "kind": "roi_set | stop_marked | note | recording_started | recording_stopped | ...",
    "camera": "camera name, empty when the event concerns the session",
    "payload": "JSON object, UTF-8",
}

CLOCK_DTYPE = np.dtype(
    [
        ("monotonic_ns", "<i8"),
        ("utc_ns", "<i8"),
        ("source", f"S{NAME_BYTES}"),
        ("rate", "<f8"),
        ("slew_until_ns", "<i8"),
        ("residual_ns", "<i8"),
    ]
)
CLOCK_UNITS = {
    "monotonic_ns": "ns, host monotonic clock: the row applies from here",
    "utc_ns": "ns since 1970-01-01 UTC at that instant",
    "source": "host | gps",
    "rate": "UTC ns per host ns from monotonic_ns to slew_until_ns (1 after it)",
    "slew_until_ns": "ns, host monotonic clock: the slew's end (-1: no slew)",
    "residual_ns": "ns, the receiver's time minus the map's this row removes (0: none)",
}

STREAMS = {
    RANGEFINDER: (RANGE_DTYPE, RANGE_UNITS),
    GPS: (GPS_DTYPE, GPS_UNITS),
    EVENTS: (EVENT_DTYPE, EVENT_UNITS),
    CLOCK: (CLOCK_DTYPE, CLOCK_UNITS),
}


UTC_UNITS = "nanoseconds since 1970-01-01 00:00:00"
"""CF time units of a UTC in ns: netCDF readers decode the column to dates."""
CONVENTIONS = "CF-1.10"
"""The root ``Conventions``: every numeric variable carries CF ``units`` (UDUNITS: a count of DN
is ``1``, its ``long_name`` says DN) and ``long_name``; time variables ``standard_name`` time."""

ATTRS: dict[str, tuple[str | None, str]] = {
    FRAMES: ("1", "raw pixel values in digital numbers (DN), row-major (row, column)"),
    "counter": ("1", "the camera's own frame counter (gaps: frames lost by the camera or link)"),
    "t_host_ns": ("ns", "host monotonic clock at receipt (arbitrary origin)"),
    "t_device_ns": ("ns", "the camera's own timestamp (-1: none given)"),
    "utc_ns": (UTC_UNITS, "UTC of receipt (t_host_ns through the clock reference)"),
    TIME: (UTC_UNITS, "UTC of the frame's receipt"),
    ROW: ("1", "pixel row, zero-based, top to bottom"),
    COL: ("1", "pixel column, zero-based, left to right"),
    REFERENCES: (
        "1",
        "background reference in DN: the fixed-pattern offset subtracted before Eq. (4)",
    ),
    "responsivity": (
        "m2 s sr",
        "calibration: DN per in-band, QE-weighted photon radiance (photons s-1 m-2 sr-1)",
    ),
    "offset_dn": ("1", "calibration: the reading at zero in-band radiance, DN"),
    "bad": ("1", "calibration: bad-pixel bits (dead=1, hot=2, noisy=4)"),
    "fit_rms_dn": ("1", "calibration: rms residual of the per-pixel linear fit, DN"),
    "temporal_noise_dn": (
        "1",
        "calibration: per-pixel temporal std, averaged over the captures, DN",
    ),
    # Compound tables: one unit per field, in their units_json (CF has no units for a compound)
    MEASUREMENTS: (None, "per-frame peak-pixel SNR (paper Eq. 4) as measured live"),
    STATES: (None, "the engine's state before a frame after frames the file lacks"),
    RANGEFINDER: (None, "laser rangefinder readings as received"),
    GPS: (None, "GPS fixes as received (or imported from a flight log)"),
    EVENTS: (None, "operator and engine events"),
    CLOCK: (None, "host monotonic clock to UTC references"),
}
"""``name -> (units, long_name)`` of every dataset (CF attributes; units None: a compound table,
its fields' units in ``units_json``)."""
TIME_VARIABLES = (TIME, "utc_ns")
"""The datasets of UTC times: CF ``standard_name`` time."""
BAD_PIXEL_FLAGS = {"flag_masks": [1, 2, 4], "flag_meanings": "dead hot noisy"}
"""The CF flag attributes of the calibration's ``bad`` map."""

DIMENSIONS: dict[str, str] = {
    MEASUREMENTS: "measurement",
    STATES: "state",
    REFERENCES: "reference",
    RANGEFINDER: "rangefinder_reading",
    GPS: "gps_fix",
    EVENTS: "event",
    CLOCK: "clock_reference",
}
"""The growing datasets without a coordinate: the name of their first dimension (a netCDF
"dimension without a variable" scale beside them, kept as long as they are)."""
