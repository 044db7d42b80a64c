"""Camera drivers: every source delivers :class:`drivers.camera.frame.Frame` objects."""
