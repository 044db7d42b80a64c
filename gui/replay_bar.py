"""The replay toolbar: play/pause, step, a seek slider, the speed and where the replay is.

Shown only when the console runs on a :class:`snrmon.acquisition.replay.player.ReplayPlayer`. It
only commands the player and shows its :class:`snrmon.acquisition.replay.player.ReplayPosition`; the
shortcuts live in :data:`snrmon.gui.actions.ACTIONS` (menu "Replay").
"""

from __future__ import annotations

from PySide6.QtCore import QPoint, Qt
from PySide6.QtWidgets import (
    QDoubleSpinBox,
    QLabel,
    QSlider,
    QStyle,
    QStyleOptionSlider,
    QToolBar,
)

SPEEDS = (0.1, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 50.0)


class ReplayBar(QToolBar):
    """Controls of one replay player (``player``: a ReplayPlayer)."""

    def __init__(self, player, actions: dict, parent=None) -> None:
        super().__init__("Replay", parent)
        self.setObjectName("toolbar_replay")
        self.player = player
        for key in ("replay_home", "replay_back", "replay_play", "replay_step"):
            if key in actions:
                self.addAction(actions[key])
        self.slider = QSlider(Qt.Orientation.Horizontal)
        self.slider.setRange(0, max(player.position().length - 1, 0))
        self.slider.setMinimumWidth(300)
        self.slider.setToolTip("Seek: timeline entry (one frame of one camera, in recorded order)")
        self.slider.setFocusPolicy(Qt.FocusPolicy.NoFocus)  # keys belong to the shortcuts
        self.slider.sliderReleased.connect(lambda: self.player.seek(self.slider.value()))
        self.addWidget(self.slider)
        self.speed = QDoubleSpinBox()
        self.speed.setRange(0.01, 1000.0)
        self.speed.setDecimals(2)
        self.speed.setSuffix(" x")
        self.speed.setValue(player.position().speed)
        self.speed.setToolTip("Replay speed, times real time (the recorded frame times)")
        self.speed.valueChanged.connect(self.player.set_speed)
        self.addWidget(self.speed)
        self.label = QLabel()
        self.label.setToolTip("Shown timeline entry / entries, recorded time (s) / duration (s)")
        self.addWidget(self.label)
        self.show_position()

    def show_position(self) -> None:
        p = self.player.position()
        if not self.slider.isSliderDown():
            self.slider.blockSignals(True)
            self.slider.setValue(max(p.index, 0))
            self.slider.blockSignals(False)
        state = "playing" if p.playing else "paused"
        self.label.setText(
            f"  {p.index + 1} / {p.length}   {p.t_s:.2f} / {p.duration_s:.2f} s   {state}"
        )

    def change_speed(self, up: bool) -> None:
        """The next speed up or down the usual ladder."""
        now = self.speed.value()
        ladder = [s for s in SPEEDS if (s > now + 1e-9 if up else s < now - 1e-9)]
        if ladder:
            self.speed.setValue(ladder[0] if up else ladder[-1])

    def slider_screen(self) -> dict[str, list[int]]:
        """Where the seek slider is on the screen (global pixels): its handle's centre and the
        groove's left and right ends with its middle row (for a hand, or xdotool, to drag)."""
        opt = QStyleOptionSlider()
        self.slider.initStyleOption(opt)
        style = self.slider.style()
        handle = style.subControlRect(
            QStyle.ComplexControl.CC_Slider, opt, QStyle.SubControl.SC_SliderHandle, self.slider
        )
        groove = style.subControlRect(
            QStyle.ComplexControl.CC_Slider, opt, QStyle.SubControl.SC_SliderGroove, self.slider
        )
        centre = self.slider.mapToGlobal(handle.center())
        left = self.slider.mapToGlobal(
            QPoint(groove.left() + handle.width() // 2, groove.center().y())
        )
        right = self.slider.mapToGlobal(
            QPoint(groove.right() - handle.width() // 2, groove.center().y())
        )
        return {"handle": [centre.x(), centre.y()], "groove": [left.x(), right.x(), left.y()]}
