"""Explicit-number scenes of the paper's two cameras, independent of ``model/``.

Owns :func:`mwir_example_scene` and :func:`lwir_example_scene`: Table 1 geometry (format, pitch,
fill factor, focal length -> IFOV) and noise tuned to the paper's clear-sky temporal noise
(6.6 DN MWIR, 5.8 DN LWIR, section 7). The radiometric numbers are the worked assumptions of
an independent worked example (MWIR: 6.57e5 e- of background, 3.37e5 e- of target contrast at 199 m
for the 15.7 cm Phantom), not measurements; the LWIR signal is set so that SNR_t with the
diffraction-limited PVF 0.45 is 24 at 199 m, as the notes' NETD shortcut gives. The twin
(``sim.twin.twin_scene_config``) computes its numbers from the camera's datasheet instead.
"""

from __future__ import annotations

import dataclasses

from snrmon.sim.noise import floor_noise_for
from snrmon.sim.scene import SceneConfig, TargetSignal

PHANTOM_SMALL_M = 0.157


def mwir_example_scene(**overrides) -> SceneConfig:
    """MWIR T2SL 1280x720, 8 um, FF 0.8, f = 16 mm (IFOV 0.5 mrad), 6.6 DN temporal noise."""
    gain = 140.0
    sky_e = 6.57e5
    config = SceneConfig(
        name="mwir",
        width_px=1280,
        height_px=720,
        gain_e_per_dn=gain,
        dn_offset=1000.0,
        sky_e=sky_e,
        floor_noise_e=floor_noise_for(6.6, gain, sky_e),
        fill_factor=0.8,
        psf_sigma_px=0.8,
        ifov_rad=8e-6 / 16e-3,
        sky_gradient_e_per_px=(0.0, 60.0),
        target=TargetSignal.inverse_square(PHANTOM_SMALL_M, 3.37e5, 199.0),
    )
    return dataclasses.replace(config, **overrides)


def lwir_example_scene(**overrides) -> SceneConfig:
    """LWIR VOx 640x480, 17 um, FF 0.9, f = 16.7 mm (IFOV 1.02 mrad), 5.8 DN temporal noise."""
    gain = 310.0
    sky_e = 1.0e6
    noise_e = 5.8 * gain
    config = SceneConfig(
        name="lwir",
        width_px=640,
        height_px=480,
        gain_e_per_dn=gain,
        dn_offset=2000.0,
        sky_e=sky_e,
        floor_noise_e=floor_noise_for(5.8, gain, sky_e),
        fill_factor=0.9,
        psf_sigma_px=0.35,
        ifov_rad=17e-6 / 16.7e-3,
        sky_gradient_e_per_px=(0.0, 200.0),
        target=TargetSignal.inverse_square(PHANTOM_SMALL_M, 24.0 * noise_e / 0.45, 199.0),
    )
    return dataclasses.replace(config, **overrides)
