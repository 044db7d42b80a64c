"""Device simulators that speak the real protocols over real interfaces."""
