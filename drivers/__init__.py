"""Device adapters: cameras, laser rangefinders and GPS.

Each driver turns bytes from hardware into typed, host-timestamped readings
(:class:`snrmon.drivers.camera.frame.Frame`,
:class:`snrmon.drivers.rangefinder.reading.RangeReading`, :class:`snrmon.drivers.gps.fix.GpsFix`)
behind the one contract of :mod:`snrmon.drivers.device`. No Qt, no analysis.
"""
