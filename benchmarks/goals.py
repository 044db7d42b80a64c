"""The speed goals the console is held to, read off ``snrmon bench``'s own figures.

Each :class:`Goal` names the figure of one benchmark section it reads and its target;
:func:`goal_rows` turns a bench result into one row per goal whose section was run: the figure,
the target and whether it is met (None: the figure was not measured, e.g. a section that
failed). ``snrmon bench`` prints them as a table after the figures and puts them in its JSON as
``"goals"``, so the README's claims are a command away.

The goals, and why:

- receipt -> SNR latency p99 <= 10 ms on both cameras while measuring, tracking and recording
  (a reading the operator sees within a third of an LWIR frame period);
- the console shows every frame the cameras deliver (shown / delivered >= 0.99) and its event
  loop is late by at most 8 ms at p99 (a click answered within half a frame);
- the same in a real window (Xvfb at 1366x768 and at 1920x1080, the demo's console at its
  first-start size): frames painted / delivered >= 0.99 per camera and the event loop late by
  at most 8 ms at p99 (``gui_window``: what the offscreen figures cannot show, a window's cost);
- ``replay --fast`` of both cameras >= 100x real time (a day's recording in minutes);
- the API's stop table of a recording within 1 s (a notebook answers at once);
- the model's four curves, expected Eq. (4) and band over 500 ranges <= 20 ms for new inputs
  after the first call (a new sky: what the console recomputes), the first <= 100 ms (the
  model dialog answers at once);
- Eq. (4) of one frame <= 20 us (independent of the frame's size);
- the recorder >= 0.9 of a plain write of the same bytes, two repeats of it (the even and the odd
  pairs, interleaved in time) within 10 % of each other;
- the recorded frames' default filter keeps a day at most 45 % of its raw size on the twin's
  frames, and its writer takes at most half of one core for both cameras (a field laptop holds
  the day, and the writer keeps up);
- the full console demo beside a busy core: 0 frames dropped and every stop with its 100 frames
  in every run;
- ``snrmon --help``, ``--version`` and every ``snrmon COMMAND --help`` <= 0.3 s of CPU (the
  command line answers at once; a command imports its work when it runs).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class Goal:
    name: str
    """What is measured, in words."""
    section: str
    """The ``snrmon bench --json`` section the figure is in."""
    figure: Callable[[dict], float]
    """The figure, from that section (a KeyError: not measured)."""
    op: str
    """``"<="`` or ``">="``."""
    target: float
    unit: str


def _ratio(num: str, den: str) -> Callable[[dict], float]:
    return lambda s: s[num] / s[den]


def _key(name: str) -> Callable[[dict], float]:
    return lambda s: s[name]


def _of_default(name: str) -> Callable[[dict], float]:
    """The default filter's figure ``<filter>_<name>`` (the compression section)."""
    return lambda s: s[f"{s['default'].replace('-', '_')}_{name}"]


def _all_runs(name: str) -> Callable[[dict], float]:
    """The worst run's count of ``name`` (a list per run)."""
    return lambda s: max(s[name]) if s[name] else math.nan


WINDOW_SCREENS = ("1366x768", "1920x1080")  # the real-window benchmark's (bench_gui_window)

GOALS: tuple[Goal, ...] = (
    Goal(
        "MWIR receipt -> SNR latency p99",
        "acquisition",
        lambda s: s["mwir"]["latency_ms_p99"],
        "<=",
        10.0,
        "ms",
    ),
    Goal(
        "LWIR receipt -> SNR latency p99",
        "acquisition",
        lambda s: s["lwir"]["latency_ms_p99"],
        "<=",
        10.0,
        "ms",
    ),
    Goal(
        "MWIR frames shown / delivered",
        "gui",
        _ratio("mwir_shown_fps", "mwir_delivered_fps"),
        ">=",
        0.99,
        "",
    ),
    Goal(
        "LWIR frames shown / delivered",
        "gui",
        _ratio("lwir_shown_fps", "lwir_delivered_fps"),
        ">=",
        0.99,
        "",
    ),
    Goal("console event loop late, p99", "gui", _key("event_loop_late_ms_p99"), "<=", 8.0, "ms"),
    *(
        goal
        for size in WINDOW_SCREENS
        for goal in (
            *(
                Goal(
                    f"{cam.upper()} frames painted / delivered, real window {size}",
                    "gui_window",
                    _ratio(f"{size}_{cam}_painted_fps", f"{size}_{cam}_delivered_fps"),
                    ">=",
                    0.99,
                    "",
                )
                for cam in ("mwir", "lwir")
            ),
            Goal(
                f"console event loop late, p99, real window {size}",
                "gui_window",
                _key(f"{size}_event_loop_late_ms_p99"),
                "<=",
                8.0,
                "ms",
            ),
        )
    ),
    Goal(
        "replay --fast, both cameras",
        "replay",
        _key("fast_realtime_factor"),
        ">=",
        100.0,
        "x real time",
    ),
    Goal(
        "snrmon.open_session(path).stops(), model included, a fresh Session",
        "replay",
        _key("api_stops_s"),
        "<=",
        1.0,
        "s",
    ),
    *(
        Goal(
            f"{cam.upper()} model, 500 ranges with band and expected Eq. (4), a new sky",
            "model",
            _key(f"{cam}_new_sky_500_ranges_ms"),
            "<=",
            20.0,
            "ms",
        )
        for cam in ("mwir", "lwir")
    ),
    *(
        Goal(
            f"{cam.upper()} model, the same, first call in a fresh process",
            "model",
            _key(f"{cam}_first_call_ms"),
            "<=",
            100.0,
            "ms",
        )
        for cam in ("mwir", "lwir")
    ),
    Goal(
        "Eq. (4) per frame, 640x480",
        "measurement",
        _key("per_frame_us_640x480"),
        "<=",
        20.0,
        "us",
    ),
    Goal(
        "Eq. (4) per frame, 1280x720",
        "measurement",
        _key("per_frame_us_1280x720"),
        "<=",
        20.0,
        "us",
    ),
    Goal("recorder / plain write", "recorder", _key("ratio"), ">=", 0.9, ""),
    Goal(
        "recorder / plain write, spread of two repeats in the run",
        "recorder",
        _key("ratio_repeat_spread"),
        "<=",
        0.10,
        "",
    ),
    Goal(
        "default frame filter, the twin's stored size / raw",
        "compression",
        _of_default("twin_size"),
        "<=",
        0.45,
        "",
    ),
    Goal(
        "default frame filter, writer CPU for both cameras / one core",
        "compression",
        _of_default("both_cameras_core"),
        "<=",
        0.5,
        "",
    ),
    Goal(
        "console demo beside a busy core, frames dropped (worst run)",
        "console",
        _all_runs("dropped_per_run"),
        "<=",
        0.0,
        "frames",
    ),
    Goal(
        "console demo beside a busy core, stops short of 100 frames (worst run)",
        "console",
        _all_runs("stops_short_per_run"),
        "<=",
        0.0,
        "stops",
    ),
    Goal(
        "command line --help / --version CPU, slowest command",
        "cli",
        _key("max_cpu_s"),
        "<=",
        0.3,
        "s",
    ),
)


def goal_rows(result: dict) -> list[dict]:
    """One row per goal whose section is in ``result`` (a ``snrmon bench`` result): ``goal``,
    ``target`` (e.g. ``"<= 10 ms"``), ``value`` (None when not measured) and ``met``."""
    rows = []
    for g in GOALS:
        section = result.get(g.section)
        if section is None:
            continue  # not run
        try:
            value: float | None = float(g.figure(section))
        except (KeyError, TypeError, ZeroDivisionError):
            value = None
        if value is not None and not math.isfinite(value):
            value = None
        met = None
        if value is not None:
            met = value <= g.target if g.op == "<=" else value >= g.target
        target = f"{g.op} {g.target:g} {g.unit}".rstrip()
        rows.append({"goal": g.name, "target": target, "value": value, "met": met})
    return rows


def format_goals(rows: list[dict]) -> str:
    """The rows as a text table: goal, figure, target, met / NOT MET / not measured."""
    lines = []
    for r in rows:
        value = "--" if r["value"] is None else f"{r['value']:.4g}"
        verdict = {True: "met", False: "NOT MET", None: "not measured"}[r["met"]]
        lines.append(f"  {r['goal']:66s} {value:>10s}  {r['target']:18s} {verdict}")
    return "\n".join(lines)
