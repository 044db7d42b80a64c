"""The console's state as a JSON file, on request (``snrmon gui|demo --status-file F.json``).

For scripts watching a session and for tests that drive the real window as a person would
(tests/gui/test_real_window.py clicks the drone with xdotool and reads the result back here).
Written atomically (a temporary file renamed over the old one) every status refresh, so a
reader never sees half a document. Strict JSON: an undefined number is ``null``.

Content::

    {"t_unix": float, "window": {"x", "y", "width", "height", "visible"},
     "view": {"theme": str, "font_scale": float, "active_camera": str, "range_large": bool,
              "stops_large": bool, "layout_fitted": bool},
     "cameras": {name: {"roi": [x, y] | null, "peak": [x, y] | null, "track_state": str,
                        "snr_mean": float | null, "snr_std": float | null, "snr_n": int,
                        "snr_sem": float | null, "range_m": float | null,
                        "range_source": str,
                        "agreement": {"rule", "expected", "lower", "upper", "ratio",
                                      "verdict"} | null,
                        "stop": {"stop", "n_frames", "n_wanted", "open"} | null,
                        "lost": [{"kind", "name", "state", "for_s"}, ...],
                        "header": str, "header_alarm": bool, "header_rect": [x, y, w, h],
                        "state_rect": [x, y, w, h], "verdicts": {tile: str},
                        "frames_shown": int, "shape": [rows, cols],
                        "screen_first_pixel": [x, y], "screen_last_pixel": [x, y],
                        "gps_xy": [x, y] | null, "palette": str, "box_screen_px": float,
                        "gps_marker": {"visible", "symbol", "size_px", "hollow", "at"},
                        "box_marker": {"visible", "symbol", "size_px", "hollow", "at"}}},
     "lrf_range_m": float | null, "gps_range_m": float | null,
     "stops": [[cell, ...], ...], "alarms": [str, ...],
     "banner": {"text": str, "visible": bool},
     "stop_table": {"columns": [key, ...], "hidden": [key, ...],
                    "colours": [{key: [fill, ink]}, ...], "ratio_rects": [[x, y, w, h] | null]},
     "recording": {"text": str, "level": str, "fill": str, "ink": str, "rect": [x, y, w, h]},
     "pointer": str,
     "replay": {"index", "length", "playing", "speed",
                "slider": {"handle": [x, y], "groove": [x_left, x_right, y]}} | null,
     "stop_table_screen": [x, y],
     "shortcuts": {"rect": [x, y, w, h], "ok": [x, y, w, h], "scroll_max": int} | null,
     "screen": [x, y, w, h] | null,
     "layout": {...},
     "messages": [str, ...]}

The camera numbers are the status snapshot the header was drawn from (``header`` is its text);
``stops`` the stop table's cells as shown (every column, hidden ones included), ``stop_table``
its columns' keys in the same order, the ones hidden for want of room, each row's coloured
cells (background and text colour, ``#rrggbb``) and where each row's measured / expected cell is
on the screen (null while scrolled out of view); ``recording`` the recording indicator's words,
level (``""``, ``"amber"``, ``"red"``) and colours; ``banner`` the alarm banner's words
(``ALARM ...`` while a device is lost, ``BACK ...`` for a while after); ``pointer`` the status
bar's readout of the pixel under the pointer; ``layout`` is
:func:`snrmon.gui.legibility.layout_report`.

``header_rect`` and ``state_rect`` are where a camera's header and its state tile's value (the
word turned red while a device is lost) are on the screen, ``verdicts`` the verdict each header
tile is coloured by (``inside``, ``near``, ``outside``, ``lost`` or ``""``); ``gps_marker`` and
``box_marker`` the GPS cue and the small-box marker as drawn (``at``: the global screen position
of their centre, ``size_px`` their width on the screen, ``hollow`` when the drone shows through
them).

``screen_first_pixel`` and ``screen_last_pixel`` are the global screen positions of the centres
of image pixel (0, 0) and (cols - 1, rows - 1) as shown now (zoom and pan included): where on
the screen a pixel of the image is. ``slider`` and ``stop_table_screen`` are global screen
positions too: the replay's seek slider (its handle, its groove's ends), the stop table's
middle, the shortcut list (F1) and its OK button while it is open; ``screen`` is the available
area of the window's screen.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import Any

from PySide6.QtCore import QPointF, Qt

from snrmon.gui.legibility import layout_report


def _num(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def _agreement(a) -> dict[str, Any] | None:
    if a is None:
        return None
    return {
        "rule": a.rule,
        "expected": _num(a.expected),
        "lower": _num(a.lower),
        "upper": _num(a.upper),
        "ratio": _num(a.ratio),
        "verdict": a.verdict,
    }


def _loss(d) -> dict[str, Any]:
    return {"kind": d.kind, "name": d.name, "state": d.state, "for_s": _num(d.for_s)}


def _stop(p) -> dict[str, Any] | None:
    if p is None:
        return None
    return {"stop": p.stop, "n_frames": p.n_frames, "n_wanted": p.n_wanted, "open": p.open}


def _replay(window) -> dict[str, Any] | None:
    if not window.replay:
        return None
    p = window.session.position()
    bar = window.replay_bar
    return {
        "index": p.index,
        "length": p.length,
        "playing": p.playing,
        "speed": p.speed,
        "slider": bar.slider_screen() if bar is not None else None,
    }


def _screen(view, x: int, y: int) -> list[int]:
    p = view.graphics.viewport().mapToGlobal(view.viewport_pos_of_pixel(x, y))
    return [p.x(), p.y()]


def _global_rect(widget) -> list[int]:
    p = widget.mapToGlobal(widget.rect().topLeft())
    return [p.x(), p.y(), widget.width(), widget.height()]


def _shortcuts(window) -> dict[str, Any] | None:
    box = window.shortcuts_dialog
    if box is None or not box.isVisible():
        return None
    ok = box.buttons.buttons()[0]
    bar = box.text.verticalScrollBar()
    return {"rect": _global_rect(box), "ok": _global_rect(ok), "scroll_max": bar.maximum()}


def _screen_rect(window) -> list[int] | None:
    screen = window.screen()
    if screen is None:
        return None
    r = screen.availableGeometry()
    return [r.x(), r.y(), r.width(), r.height()]


def _marker(view, item) -> dict[str, Any]:
    """A pxMode scatter marker of a camera view: shown or not, its shape and screen size, and
    where its (single) point is on the screen."""
    xs, ys = item.getData()
    at = None
    if len(xs):
        scene = view.view.mapViewToScene(QPointF(float(xs[0]), float(ys[0])))
        p = view.graphics.viewport().mapToGlobal(view.graphics.mapFromScene(scene))
        at = [p.x(), p.y()]
    return {
        "visible": item.isVisible(),
        "symbol": item.opts["symbol"],
        "size_px": float(item.opts["size"]),
        "hollow": item.opts["brush"].color().alpha() == 0,
        "at": at,
    }


def _stop_table(table) -> dict[str, Any]:
    """The stop table's column keys, the hidden ones, each row's coloured cells and where each
    row's measured / expected cell is on the screen."""
    keys = [c.key for c in table.table.cols]
    colours: list[dict[str, list[str]]] = []
    rects: list[list[int] | None] = []
    ratio = keys.index("ratio") if "ratio" in keys else None
    area = table.viewport().rect()
    for i in range(table.proxy.rowCount()):
        row: dict[str, list[str]] = {}
        for j, key in enumerate(keys):
            index = table.proxy.index(i, j)
            fill = index.data(Qt.ItemDataRole.BackgroundRole)
            ink = index.data(Qt.ItemDataRole.ForegroundRole)
            if fill is not None or ink is not None:
                row[key] = [
                    fill.color().name() if fill is not None else "",
                    ink.color().name() if ink is not None else "",
                ]
        colours.append(row)
        rect = None
        if ratio is not None and not table.isColumnHidden(ratio):
            r = table.visualRect(table.proxy.index(i, ratio))
            if area.contains(r):
                p = table.viewport().mapToGlobal(r.topLeft())
                rect = [p.x(), p.y(), r.width(), r.height()]
        rects.append(rect)
    return {
        "columns": keys,
        "hidden": list(table.hidden_columns),
        "colours": colours,
        "ratio_rects": rects,
    }


def _recording(label) -> dict[str, Any]:
    fill, ink = label.colours()
    return {
        "text": label.text(),
        "level": label.level,
        "fill": fill,
        "ink": ink,
        "rect": _global_rect(label),
    }


def _centre(widget) -> list[int]:
    p = widget.mapToGlobal(widget.rect().center())
    return [p.x(), p.y()]


def console_state(window) -> dict[str, Any]:
    """What the console shows now (see the module docstring)."""
    geo = window.frameGeometry()
    st = window.last_status
    cameras = {}
    for name, panel in window.panels.items():
        cs = st.cameras.get(name) if st is not None else None
        rows, cols = panel.view.shape
        m = cs.last if cs is not None else None
        last = m.result if m is not None else None
        cameras[name] = {
            "roi": list(cs.roi_xy) if cs is not None and cs.roi_xy is not None else None,
            "peak": [last.peak_x, last.peak_y] if last is not None else None,
            "track_state": cs.track_state.value if cs is not None else "",
            "snr_mean": _num(m.snr_mean) if m is not None else None,
            "snr_std": _num(m.snr_std) if m is not None else None,
            "snr_n": m.snr_n if m is not None else 0,
            "snr_sem": _num(cs.snr_sem) if cs is not None else None,
            "range_m": _num(m.range_m) if m is not None else None,
            "range_source": m.range_source if m is not None else "",
            "agreement": _agreement(cs.agreement) if cs is not None else None,
            "stop": _stop(cs.stop) if cs is not None else None,
            "lost": [_loss(d) for d in cs.lost] if cs is not None else [],
            "header": panel.header.text(),
            "header_alarm": panel.header.alarm,
            "header_rect": _global_rect(panel.header),
            "state_rect": _global_rect(panel.header.tiles["state"].value),
            "verdicts": {k: tile.verdict for k, tile in panel.header.tiles.items()},
            "frames_shown": panel.view.frames_shown,
            "shape": [rows, cols],
            "screen_first_pixel": _screen(panel.view, 0, 0),
            "screen_last_pixel": _screen(panel.view, cols - 1, rows - 1),
            "gps_xy": [_num(v) for v in cs.gps_xy] if cs is not None and cs.gps_xy else None,
            "palette": panel.view.palette,
            "box_screen_px": panel.view.box_screen_px(),
            "gps_marker": _marker(panel.view, panel.view.gps_marker),
            "box_marker": _marker(panel.view, panel.view.box_marker),
        }
    return {
        "t_unix": time.time(),
        "window": {
            "x": geo.x(),
            "y": geo.y(),
            "width": geo.width(),
            "height": geo.height(),
            "visible": window.isVisible(),
        },
        "view": {
            "theme": window.theme_name,
            "font_scale": window.font_scale,
            "active_camera": window.active_camera,
            "range_large": window.range_large,
            "stops_large": window.large == "stops",
            "layout_fitted": window.layout_fitted,
        },
        "cameras": cameras,
        "lrf_range_m": _num(st.lrf_range_m) if st is not None else None,
        "gps_range_m": _num(st.gps_range_m) if st is not None else None,
        "stops": window.stop_table.cells(),
        "stop_table": _stop_table(window.stop_table),
        "alarms": list(st.alarms) if st is not None else [],
        "banner": {"text": window.banner.text(), "visible": window.banner.isVisible()},
        "recording": _recording(window.recording_label),
        "pointer": window.pointer_label.text(),
        "replay": _replay(window),
        "stop_table_screen": _centre(window.stop_table.viewport()),
        "shortcuts": _shortcuts(window),
        "screen": _screen_rect(window),
        "layout": layout_report(window),
        "messages": window.messages[-20:],
    }


def write_status_file(window, path: str | Path) -> None:
    """Replace ``path`` with the console's state (atomically)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(console_state(window), allow_nan=False))
    os.replace(tmp, path)
