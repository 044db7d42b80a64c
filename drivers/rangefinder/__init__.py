"""Laser rangefinder drivers; every one delivers
:class:`snrmon.drivers.rangefinder.reading.RangeReading`."""
