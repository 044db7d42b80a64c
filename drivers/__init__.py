"""Device adapters: cameras, laser rangefinders and GPS.

Each driver turns bytes from hardware into typed, host-timestamped readings
(:class:`drivers.camera.frame.Frame`, :class:`drivers.rangefinder.reading.RangeReading`,
:class:`drivers.gps.fix.GpsFix`) behind the one contract of :mod:`drivers.device`.
No Qt, no analysis.
"""
