"""One word, one meaning: every option name and positional argument of every ``snrmon``
command, its metavar and what it means, and the old spellings that still work for a while.

The table is the rule, not a description: ``tests/test_cli_vocabulary.py`` walks every parser
and fails when an option is missing here, takes another metavar than the one here, is a flag
here and a value there, has a default its help does not state, or when a command that prints a
result has no ``--json``; docs/cli.md lists the same table (the test compares them).

A metavar of ``None`` is a flag (takes no value); ``a|b|c`` lists the choices of an option that
takes one of them.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Word:
    metavar: str | None
    """What the value looks like (``--help`` shows it); None: a flag."""
    meaning: str


OPTIONS: dict[str, Word] = {
    # what is measured, and where
    "--camera": Word("NAME", "a camera by its name in the session or the rig (mwir, lwir)"),
    "--cameras": Word("NAME,...", "the cameras to simulate, by name"),
    "--sensor": Word("mwir|lwir|FILE", "a sensor preset, or a sensor TOML file"),
    "--intrinsics": Word("F_M,PITCH_UM,W,H", "camera intrinsics given directly"),
    "--target": Word("uav1|uav2|FILE", "a target preset, or a target TOML file"),
    "--target-at": Word("LAT,LON,ALT", "a target's position: degrees, degrees, metres"),
    "--site": Word("LAT,LON,ALT", "the camera's position: degrees, degrees, metres"),
    "--pointing": Word("AZ,EL,ROLL", "a camera's pointing in degrees"),
    "--initial": Word("AZ,EL,ROLL", "the starting pointing of a fit, degrees"),
    "--at": Word("X,Y", "a point in a frame: column X, row Y, zero-based"),
    "--click": Word("CAMERA:X,Y", "the operator's click on a camera at start: its ROI at X,Y"),
    "--roi": Word("X0,Y0,X1,Y1", "a rectangle of a frame, both corners included"),
    "--roi-px": Word("PX", "the half size of the square region around the drone, pixels"),
    "--size": Word("WxH", "a frame size in pixels (a camera's sub-array)"),
    "--window-size": Word("WxH", "the console window's size in screen pixels"),
    "--frames": Word("START:STOP", "a frame range, zero-based, STOP excluded"),
    "--seconds": Word("START:STOP", "a time range in seconds from a camera's first frame"),
    "--n-frames": Word("N", "a count of frames to use"),
    "--window-frames": Word("N", "the running window, in frames"),
    "--frame-table": Word(None, "also write a table with a row per frame"),
    "--stop": Word("N", "a stop number as in the stop table"),
    "--stops": Word("M,M,...", "the hover ranges of a flight, metres"),
    "--search": Word("N", "the search window's side, pixels (odd)"),
    "--box": Word("N", "the measurement box's side, pixels (odd)"),
    "--background": Word("rim|X0,Y0,X1,Y1", "the background pixels: the box rim or a rectangle"),
    "--detrend": Word(None, "remove a plane from the background"),
    "--saturation": Word("DN", "the saturation level, DN"),
    "--track": Word(None, "follow the drone from the click"),
    "--tracking": Word("recorded|on|off", "follow the drone as recorded, or force it on/off"),
    "--no-track": Word(None, "keep the search window where clicked"),
    # files read
    "--config": Word("FILE.toml", "a session config"),
    "--calibration": Word("CAL.npz", "a radiometric calibration (snrmon calibrate)"),
    "--no-calibration": Word(None, "no blackbody calibration before the flight"),
    "--blackbody": Word("STACK:TEMP_C", "a stack of a blackbody and its temperature in C"),
    "--pairs": Word("FILE.csv", "(pixel, GPS position) pairs"),
    "--settings": Word("FILE.toml", "re-analysis settings"),
    "--replay": Word(
        "RECORDING", "a recording to play in the console: a session, or another tool's"
    ),
    "--format": Word(
        "dji_csv|dji_srt|nmea|tlog|dataflash|ulog|ubx",
        "a flight log's kind, instead of the one found from its content",
    ),
    "--utc-offset": Word("+HH:MM", "a log's local time minus UTC"),
    "--dji": Word("LOG", "a DJI AirData CSV (kept for old scripts: LOG --format dji_csv)"),
    "--srt": Word("LOG", "a DJI SRT (kept for old scripts: LOG --format dji_srt)"),
    "--nmea": Word("LOG", "an NMEA 0183 log (kept for old scripts: LOG --format nmea)"),
    "--tlog": Word("LOG", "a MAVLink telemetry log (kept for old scripts: LOG --format tlog)"),
    # files written
    "--out": Word("PATH", "the command's main output (file or folder), also -o"),
    "--report": Word("REPORT.pdf|png", "a report written beside the main output"),
    "--csv": Word("TABLE.csv", "a stop table written as CSV"),
    "--screenshot": Word("FILE.png", "the window saved at the end"),
    "--status-file": Word("FILE.json", "the console's state, rewritten 5 times a second"),
    "--target-out": Word("FILE.toml", "a target TOML written from the result"),
    "--target-name": Word("NAME", "the name written into --target-out"),
    "--record-dir": Word("DIR", "where the recordings will go"),
    "--write": Word(None, "keep the result in the recording itself"),
    "--no-record": Word(None, "keep the result nowhere"),
    "--json": Word(None, "print the result as strict JSON on stdout"),
    "--compression": Word(
        "none|lz4|bitshuffle-lz4|zstd|gzip", "the recorded frames' lossless filter"
    ),
    # time and pace
    "--duration": Word("S", "how long, in seconds"),
    "--speed": Word("X", "the pace, in times real time"),
    "--fast": Word(None, "read only the pixels around the track"),
    "--timeout": Word("S", "give up after S seconds"),
    "--wait": Word("S", "how long each device may take to answer, seconds"),
    "--hover-s": Word("S", "the hover time per stop, flight seconds"),
    "--transit-mps": Word("M_S", "the transit speed between stops, m/s"),
    "--offset-s": Word("S", "seconds added to a log's times"),
    "--max-offset-s": Word("S", "the offset search's half width, seconds"),
    # the simulated day and the model's inputs
    "--seed": Word("N", "the seed of every simulated device"),
    "--headless": Word(None, "no window"),
    "--template": Word(
        None, "print a session config with every key, its default and what it expects"
    ),
    "--fpn": Word(None, "add fixed-pattern noise to the simulated frames"),
    "--sky-temp-c": Word("T", "the sky's (background's) temperature, C"),
    "--air-temp-c": Word("T", "the air temperature along the path, C"),
    "--rh": Word("PCT", "relative humidity, %"),
    "--dew-point-c": Word("TD", "dew point, C"),
    "--pressure-hpa": Word("P", "air pressure, hPa"),
    "--visibility-km": Word("V", "meteorological visibility, km"),
    "--footprint": Word(
        "square|outline", "the model's small target: the paper's square or the measured outline"
    ),
    "--aerosol": Word("rural|maritime|urban|none", "the LOWTRAN7 aerosol model (none: no aerosol)"),
    "--season": Word(
        "us_std_1976|tropical|midlat_summer|midlat_winter|subarctic_summer|subarctic_winter",
        "the standard atmosphere for readings not given",
    ),
    "--atmosphere": Word("default|none|TAU|FILE", "the atmosphere's transmission"),
    "--atmosphere-path-m": Word("M", "the path length of a tape7/CSV spectrum, metres"),
    "--spatial-noise": Word("E|Kx|CLUTTER", "the spatial noise of the model"),
    "--ranges": Word("R,...", "slant ranges, metres"),
    "--max-range-m": Word("M", "the last range plotted, metres"),
    "--psf": Word("airy|gaussian|airy+gaussian", "the point spread function's kind"),
    "--psf-blur-px": Word("PX", "the Gaussian blur of the camera's PSF, pixels"),
    "--no-psf-correction": Word(None, "no correction for the PSF's mixing"),
    "--f-number": Word("N", "the optics' f-number"),
    "--pitch-um": Word("UM", "the detector pitch, micrometres"),
    "--wavelength-um": Word("UM", "one wavelength, micrometres"),
    "--band": Word("L1,L2", "a band, micrometres"),
    "--sigma-px": Word("PX", "a Gaussian's sigma, pixels"),
    "--fill-factor": Word("F", "the detector's area fill factor"),
    "--target-size-px": Word("D", "the target's size, pixels"),
    "--temp-k": Word("K", "a blackbody temperature, kelvin"),
    "--apparent": Word(None, "every temperature as seen, through the air"),
    "--method": Word("otsu|ksigma", "the segmentation of the drone from the sky"),
    "--min-frames": Word("N", "the fewest valid frames a stop must give"),
    "--min-size-px": Word("PX", "the smallest dimension measured, pixels"),
    "--noise": Word("model|measured", "the model's noise: its own or the measured 3D noise"),
    "--no-paper-curves": Word(None, "leave out the paper's switched curves"),
    # devices and machines
    "--port": Word("URL", "a serial port path or pyserial URL"),
    "--protocol": Word("nmea|gpsd|mavlink|trupulse|ldm", "a device's protocol"),
    "--baud": Word("BAUD", "a serial line's speed"),
    "--count": Word("N", "a count of readings"),
    "--allow-no-checksum": Word(None, "accept NMEA sentences without a checksum"),
    "--replace": Word(None, "replace a live GPS stream"),
    "--disk-test-mb": Word("MB", "how much to write when measuring the disk"),
    "--scheduler": Word("ADDRESS", "a Dask scheduler's address"),
    "--workers": Word("N", "processes of the local cluster"),
    "--only": Word("KEYS", "comma-separated benchmark keys"),
    "--theme": Word("dark|daylight", "the console's look"),
    "--font-scale": Word("X", "every text's size over normal"),
    # every command
    "--verbose": Word(None, "more on stderr (-v, -vv)"),
    "--quiet": Word(None, "errors only on stderr"),
    "--log-file": Word("FILE", "also write the log to FILE"),
}
"""Every option name (its long form) and what it is, in every command that takes it."""

POSITIONALS: dict[str, Word] = {
    "session": Word("SESSION.h5", "a snrmon session file"),
    "sessions": Word("SESSION.h5", "snrmon session files"),
    "stack": Word("STACK", "frames: a stack file of another tool (or a session)"),
    "recording": Word("RECORDING", "a snrmon session, or another tool's recording"),
    "kind": Word("gps|lrf", "what kind of device is on the port"),
    "log": Word("LOG", "a flight log of the drone, its kind found from its content"),
}
"""Every positional argument's name (its ``dest``) and what it is."""

DEPRECATED: dict[tuple[str, str], str] = {
    ("snrmon calibrate", "--camera"): "--sensor",
    ("snrmon calibrate", "--output"): "--out",
    ("snrmon campaign", "--frames"): "--frame-table",
    ("snrmon characterize", "--frames"): "--n-frames",
    ("snrmon demo", "--size"): "--window-size",
    ("snrmon geo pixel", "--camera"): "--intrinsics",
    ("snrmon geo pixel", "--target"): "--target-at",
    ("snrmon geo calibrate", "--camera"): "--intrinsics",
    ("snrmon gui", "--size"): "--window-size",
    ("snrmon hil", "--camera"): "--cameras",
    ("snrmon hil", "--window"): "--size",
    ("snrmon measure", "--window"): "--window-frames",
    ("snrmon model snr", "--background-temp-c"): "--sky-temp-c",
    ("snrmon model netd", "--background-temp-c"): "--sky-temp-c",
    ("snrmon model plot", "--background-temp-c"): "--sky-temp-c",
    ("snrmon model plot", "--output"): "--out",
    ("snrmon record", "--roi"): "--click",
    ("snrmon replay", "--track"): "--tracking",
    ("snrmon report", "--output"): "--out",
}
"""``(command, old spelling): new spelling``: the old one still works, with a one-line warning
on stderr (``snrmon.cli.add_deprecated_alias``)."""

NO_JSON: dict[str, str] = {
    "snrmon gui": "the console: a window, no result printed",
}
"""Commands that print no result, and why; every other command takes ``--json``."""
