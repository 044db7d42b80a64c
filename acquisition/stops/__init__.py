"""Range stops: detection from rangefinder and GPS, and the SNR-versus-range table built stop by
stop."""
