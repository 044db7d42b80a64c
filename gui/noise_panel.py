"""The noise panel (paper section 6): per camera, total, temporal and spatial noise in DN.

Every value is a field of :class:`snrmon.acquisition.engine.status.CameraStatus` computed on the
processing side (acquisition/measure/track_noise.py); the panel only formats it. "--" until the
pipeline has a background to measure (a track, or a clear-sky rectangle in the measurement config).
"""

from __future__ import annotations

import math

from PySide6.QtWidgets import QGridLayout, QLabel, QVBoxLayout, QWidget

from snrmon.acquisition.engine.status import SessionStatus

COLUMNS = (
    ("noise_total_dn", "total", "Total noise (DN): std of the background pixels of one frame"),
    (
        "noise_temporal_dn",
        "temporal",
        "Temporal noise (DN): std of the difference with the previous frame over the same pixels, "
        "divided by sqrt(2) (a difference of two frames carries sqrt(2) times the single-frame "
        "temporal noise)",
    ),
    (
        "noise_spatial_dn",
        "spatial",
        "Spatial (fixed-pattern) noise (DN): sqrt(total^2 - temporal^2)",
    ),
)
REGION_TIP = (
    "Background: the clear-sky rectangle of the measurement config if there is one, else a "
    "41 x 41 px square around the tracked peak without the 7 x 7 box; raw camera pixels, "
    "re-estimated 4 times per second."
)


class NoisePanel(QWidget):
    """A grid: one row per camera, total / temporal / spatial noise (DN)."""

    def __init__(self, cameras: list[str], parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.labels: dict[tuple[str, str], QLabel] = {}
        grid = QGridLayout()
        for col, (_, title, tip) in enumerate(COLUMNS, start=1):
            head = QLabel(f"{title} (DN)")
            head.setToolTip(tip)
            grid.addWidget(head, 0, col)
        for row, cam in enumerate(cameras, start=1):
            name = QLabel(cam.upper())
            name.setToolTip(f"{cam}: {REGION_TIP}")
            grid.addWidget(name, row, 0)
            for col, (field, _title, tip) in enumerate(COLUMNS, start=1):
                value = QLabel("--")
                value.setToolTip(f"{cam} {tip}")
                grid.addWidget(value, row, col)
                self.labels[(cam, field)] = value
        lay = QVBoxLayout(self)
        lay.setContentsMargins(4, 4, 4, 4)
        lay.addLayout(grid)
        lay.addStretch(1)
        self.setToolTip(REGION_TIP)

    def show_status(self, st: SessionStatus) -> None:
        for (cam, field), label in self.labels.items():
            cs = st.cameras.get(cam)
            value = getattr(cs.figures, field) if cs is not None else math.nan
            text = f"{value:.2f}" if math.isfinite(value) else "--"
            if label.text() != text:
                label.setText(text)
