"""Eq. (4), the peak-pixel SNR, and its statistics: backgrounds, rim contamination, running
mean/std, section 6 noise."""
