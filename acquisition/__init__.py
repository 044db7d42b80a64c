"""The pipeline: measurement (paper Eq. 4), tracking, time base, recording and replay.

Owns the per-frame peak-SNR measurement and its running statistics, noise analysis
(paper section 6), device threads, the synchronisation of range and GPS to frames,
range-stop detection, GPS-to-pixel projection, and the HDF5 session record. No Qt.
"""
