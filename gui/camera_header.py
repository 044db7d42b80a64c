"""The header above a camera's image: what the operator reads at arm's length.

Six tiles, each a small caption over a large value and a note, wrapped onto as many lines as the
panel's width needs (never cut): the camera and its track state; the range the measurement is
at (its source, and the rangefinder's and the GPS's own); SNR(100) with its error of the mean;
the model's expected Eq. (4) reading at that range (which background rule and which PSF,
"preset PSF" or "fitted PSF", in full in the tile's tooltip; its uncertainty band); measured /
expected, filled green inside the band, amber near it, red outside; the stop's progress (n of
100 frames).

Every number is a field of the session's status
(:class:`snrmon.acquisition.engine.status.CameraStatus`: ``last``, ``snr_sem``, ``agreement``,
``stop``, ``model.psf_source``; :class:`~snrmon.acquisition.engine.status.SessionStatus` for the
rangefinder and GPS); the header only formats them.
"""

from __future__ import annotations

import math

from PySide6.QtCore import Qt
from PySide6.QtGui import QFont
from PySide6.QtWidgets import QFrame, QLabel, QVBoxLayout, QWidget

from snrmon.acquisition.engine.status import CameraStatus, SessionStatus
from snrmon.acquisition.prediction import psf_label
from snrmon.acquisition.track.config import TrackState
from snrmon.gui import theme as th
from snrmon.gui.flow_layout import FlowLayout
from snrmon.gui.model_curves import curve_label

VALUE_FACTOR = 1.6  # the values' size over the console's text: readable from arm's length
NOTE_FACTOR = 0.9
LOST = "lost"  # the state tile's verdict while a device the camera depends on is lost
VERDICT_WORDS = {"inside": "inside", "near": "near", "outside": "outside", "": "band"}
STATE_VERDICT = {
    TrackState.TRACKING: "inside",
    TrackState.FIXED: "inside",
    TrackState.GPS_CUED: "near",
    TrackState.REACQUIRING: "near",
    TrackState.OCCLUDED: "near",
    TrackState.LOST: "outside",
}
# The widest text each value takes, so a tile keeps its width while the numbers change.
TEMPLATES = {
    "state": "reacquiring",
    "range": "8888.8 m",
    "snr": "88.88 ± 8.88",
    "expected": "8888.8",
    "ratio": "88.88",
    "stop": "100 / 100",
}
TIPS = {
    "state": "The camera, the frames per second it delivered to the console over the last 2 s "
    "(not the rate it was asked for) and what its track is doing (docs/tracking.md)",
    "range": "The range of the last measured frame (m) and where it came from: the rangefinder "
    "(LRF) while its reading is fresh, else the GPS slant range; the note gives both (m)",
    "snr": "SNR(100): the mean of the peak SNR (Eq. 4) over the last 100 valid frames +/- its "
    "error of the mean (the frames' autocorrelation counted); the note: frames and std",
    "expected": "What the model expects Eq. (4) to read at this range, under the background "
    "rule named in the note (its uncertainty band: the ratio's note, the plot, the stop table), "
    "and the PSF it used (preset: the sensor's; fitted: from this flight's stops)",
    "ratio": "Measured SNR(100) / expected: green inside the model's uncertainty band, amber "
    "within two errors of the mean of it (near), red outside; the note: the verdict and the "
    "band as a ratio of the expected reading",
    "stop": "The stop's progress: consecutive valid frames of the 100 a stop-table row is "
    "summarised from (paper section 7)",
}


def _num(value: float | None, fmt: str) -> str:
    return "--" if value is None or not math.isfinite(value) else format(value, fmt)


def _m(value: float | None) -> str:
    return "--" if value is None or not math.isfinite(value) else f"{value:.1f} m"


def rule_words(rule: str) -> str:
    """The background rule of an expected reading, in words (its label less the common
    "expected Eq. (4)" part)."""
    label = curve_label(rule)
    for prefix in ("expected Eq. (4), ", "expected Eq. (4) "):
        if label.startswith(prefix):
            return label[len(prefix) :]
    return label


def _range_sources(st: SessionStatus | None) -> tuple[tuple[str, float | None], ...]:
    return (
        ("LRF", st.lrf_range_m if st is not None else None),
        ("GPS", st.gps_range_m if st is not None else None),
    )


def _ago(age_s: float | None) -> str:
    return "" if age_s is None else f" {age_s:.0f} s ago"


def _source_words(kind: str, value: float | None, cs: CameraStatus) -> str:
    """A range source's last value, or, while it is lost, that it is lost and for how long
    (its last value is then old: never shown as if live)."""
    loss = cs.lost_kind(kind)
    if loss is not None:
        age = "" if loss.for_s is None else f" {loss.for_s:.0f} s"
        return f"{kind} lost{age}"
    return f"{kind} {_num(value, '.1f')}"


def header_fields(name: str, cs: CameraStatus, st: SessionStatus | None) -> dict[str, tuple]:
    """{tile: (caption, value, note, verdict)} of one camera, formatted from its status."""
    m = cs.last
    measuring = m is not None and m.snr_n > 0
    fields: dict[str, tuple] = {}
    state = cs.track_state
    why = f" ({cs.track_reason})" if cs.track_reason else ""
    if cs.lost:  # what is lost and for how long, in place of the track's state
        fields["state"] = (
            f"{name.upper()}  {cs.fps:.1f} fps",
            " + ".join(d.kind for d in cs.lost) + " LOST",
            ", ".join(d.words() for d in cs.lost),
            LOST,
        )
    else:
        fields["state"] = (
            f"{name.upper()}  {cs.fps:.1f} fps",
            state.value,
            why.strip(" ()") or ("click the drone" if state is TrackState.IDLE else ""),
            STATE_VERDICT.get(state, ""),
        )
    fields["range"] = (
        f"range ({(m.range_source or 'no range').upper() if m is not None else 'none'})",
        _m(m.range_m if m is not None else None),
        ", ".join(_source_words(kind, value, cs) for kind, value in _range_sources(st)),
        "",
    )
    # the camera itself lost: no frame since, its numbers are its last ones, said so
    stale = cs.lost_kind("camera")
    last = None if stale is None else "last frame" + _ago(stale.for_s)
    if measuring:
        snr = f"{m.snr_mean:.2f} ± {_num(cs.snr_sem, '.2f')}"
        note = last or f"n {m.snr_n}, std {_num(m.snr_std, '.2f')}"
    else:
        snr, note = "--", "no frames measured"
    fields["snr"] = ("SNR(100) ± error", snr, note, "")
    a = cs.agreement
    psf = psf_label(cs.model.psf_source)  # which PSF the expected reading was computed with
    if a is not None:
        note = rule_words(a.rule) + (f", {psf}" if psf else "")
        fields["expected"] = ("expected Eq. (4)", f"{a.expected:.1f}", note, "")
        band = f"{a.ratio_lower:.2f}–{a.ratio_upper:.2f}" if a.lower != a.upper else "none"
        fields["ratio"] = (
            "measured / expected",
            _num(a.ratio, ".2f"),
            f"{VERDICT_WORDS.get(a.verdict, a.verdict)}: {band}" + (f", {last}" if last else ""),
            a.verdict if last is None else "",  # a dead camera's agreement is not lit as live
        )
    else:
        why = "no model" if not cs.model.curves else "no measurement"
        fields["expected"] = ("expected Eq. (4)", "--", why + (f", {psf}" if psf else ""), "")
        fields["ratio"] = ("measured / expected", "--", why, "")
    p = cs.stop
    if p is None:
        fields["stop"] = ("stop", "--", "no stop yet", "")
    else:
        where = "hovering" if p.open else "ended"
        if p.complete:
            how = "complete"
        elif p.open:
            how = "collecting"
        else:
            how = "ended short"
        mark = " M" if p.manual else ""
        fields["stop"] = (
            f"stop {p.stop}{mark}, {where}",
            f"{p.n_frames} / {p.n_wanted}",
            f"frames, {how}",
            "inside" if p.complete else "",
        )
    return fields


class _Tile(QWidget):
    """Caption over value over note."""

    def __init__(self, key: str) -> None:
        super().__init__()
        self.key = key
        self.caption = QLabel()
        self.value = QLabel()
        self.note = QLabel()
        for label in (self.caption, self.value, self.note):
            label.setTextFormat(Qt.TextFormat.PlainText)
        self.value.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignVCenter)
        self.setToolTip(TIPS[key])
        lay = QVBoxLayout(self)
        lay.setContentsMargins(4, 1, 4, 1)
        lay.setSpacing(0)
        lay.addWidget(self.caption)
        lay.addWidget(self.value)
        lay.addWidget(self.note)
        self.verdict = ""

    def set_fonts(self, value: QFont, small: QFont) -> None:
        self.value.setFont(value)
        self.caption.setFont(small)
        self.note.setFont(small)
        pad = self.value.fontMetrics().horizontalAdvance("  ")
        self.value.setMinimumWidth(
            self.value.fontMetrics().horizontalAdvance(TEMPLATES[self.key]) + pad
        )

    def set_texts(self, caption: str, value: str, note: str, verdict: str) -> None:
        for label, text in ((self.caption, caption), (self.value, value), (self.note, note)):
            if label.text() != text:
                label.setText(text)
        if verdict != self.verdict:
            self.verdict = verdict
            self.restyle()

    def restyle(self) -> None:
        t = th.current()
        muted = f"color: {t.muted};"
        self.caption.setStyleSheet(muted)
        self.note.setStyleSheet(muted)
        fill, ink = t.verdicts.get(self.verdict, ("", t.text))
        if self.verdict == LOST:  # a lost device: white on the alarm's red, not to be missed
            self.value.setStyleSheet(
                f"background: {th.ALARM}; color: #ffffff; border-radius: 4px; padding: 0px 6px;"
            )
        elif self.key == "ratio" and fill:  # the agreement at a glance: a filled badge
            self.value.setStyleSheet(
                f"background: {fill}; color: {ink}; border-radius: 4px; padding: 0px 6px;"
            )
        elif self.key in ("state", "stop") and fill:
            self.value.setStyleSheet(f"color: {fill};")
        else:
            self.value.setStyleSheet(f"color: {t.text};")

    def text(self) -> str:
        return " ".join(t for t in (self.caption.text(), self.value.text(), self.note.text()) if t)


class CameraHeader(QFrame):
    """The header of one camera (module docstring); :meth:`show_status` refreshes it."""

    def __init__(self, name: str, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.name = name
        self.active = False
        self.alarm = False
        self.setObjectName("camera_header")
        self.tiles = {key: _Tile(key) for key in TEMPLATES}
        flow = FlowLayout(self, spacing=4)
        flow.setContentsMargins(2, 2, 2, 2)
        for tile in self.tiles.values():
            flow.addWidget(tile)
        self.fields: dict[str, tuple] = {}
        self.apply_theme(1.0)
        for key, tile in self.tiles.items():
            tile.set_texts(key, "--", "", "")

    def apply_theme(self, font_scale: float) -> None:
        """The current theme's colours, the values at :data:`VALUE_FACTOR` x the text."""
        value = th.scaled_font(font_scale, VALUE_FACTOR, bold=True)
        small = th.scaled_font(font_scale, NOTE_FACTOR)
        for tile in self.tiles.values():
            tile.set_fonts(value, small)
            tile.restyle()
        self._frame_style()

    def set_active(self, active: bool) -> None:
        """The camera the operator's track keys (T, Esc) act on: outlined in the accent."""
        if active != self.active:
            self.active = active
            self._frame_style()

    def _frame_style(self) -> None:
        t = th.current()
        colour = t.accent if self.active else t.panel
        if self.alarm:
            colour = th.ALARM
        self.setStyleSheet(
            f"QFrame#camera_header {{ border: 2px solid {colour}; border-radius: 4px; }}"
        )

    def show_status(self, cs: CameraStatus, st: SessionStatus | None) -> None:
        """Refresh the tiles (the panel then places the header at the height they need)."""
        self.fields = header_fields(self.name, cs, st)
        for key, (caption, value, note, verdict) in self.fields.items():
            self.tiles[key].set_texts(caption, value, note, verdict)
        psf = f"\nThe model's PSF: {cs.model.psf_source}" if cs.model.psf_source else ""
        tip = TIPS["expected"] + psf  # the PSF in full where the note names it short
        if self.tiles["expected"].toolTip() != tip:
            self.tiles["expected"].setToolTip(tip)
        if bool(cs.lost) != self.alarm:
            self.alarm = bool(cs.lost)  # the whole header outlined in red while a device is lost
            self._frame_style()

    def text(self) -> str:
        """Everything the header shows, tile by tile (the status file, tests)."""
        return " | ".join(tile.text() for tile in self.tiles.values())
