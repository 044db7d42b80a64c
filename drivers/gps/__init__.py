"""GPS and drone-telemetry drivers: every source delivers :class:`snrmon.drivers.gps.fix.GpsFix`."""
