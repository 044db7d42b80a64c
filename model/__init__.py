"""The physics: radiometry, atmosphere, optics (PSF, PVF), detector noise and SNR versus range.

Implements the sensor model of Gemar, Driggers et al., Opt. Eng. 58(5) 053107 (2019), section 2
(Eqs. 1-3) and sections 8-9, with the sensor and target presets of its Table 1 and section 3.
Pure numpy/scipy: no I/O beyond loading presets and atmosphere files, no Qt.

Entry points: :func:`snrmon.model.presets.load_sensor`, :func:`snrmon.model.presets.load_target`,
:func:`snrmon.model.snr.predict` (the four curves of Figs. 7-10), :mod:`snrmon.model.pvf` and
:mod:`snrmon.model.psf` (PVF and PSFs), :mod:`snrmon.model.noise` (Eq. 1). See docs/model.md.
"""
