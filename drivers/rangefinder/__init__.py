"""Laser rangefinder drivers; every one delivers
:class:`drivers.rangefinder.reading.RangeReading`."""
