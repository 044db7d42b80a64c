"""Simulated devices and scenes for hardware-in-loop runs and tests.

A sky-and-drone scene renderer with radiometry and optics of its own (it reads the model's
presets and atmosphere data, never its radiometric code), a flight plan, and device simulators
that speak the drivers' real protocols over real interfaces (pseudo-terminals, sockets,
shared memory). It never reaches into :mod:`snrmon.drivers`.
"""
