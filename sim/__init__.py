"""Simulated devices and scenes for hardware-in-loop runs and tests.

A sky-and-drone scene renderer built on :mod:`snrmon.model`, a flight plan, and device simulators
that speak the drivers' real protocols over real interfaces (pseudo-terminals, sockets,
shared memory). It never reaches into :mod:`snrmon.drivers`.
"""
