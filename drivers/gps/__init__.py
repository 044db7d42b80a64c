"""GPS and drone-telemetry drivers: every source delivers :class:`drivers.gps.fix.GpsFix`."""
