"""Camera drivers: every source delivers :class:`snrmon.drivers.camera.frame.Frame` objects."""
