"""Eq. (4), the peak-pixel SNR, and its statistics: backgrounds (the rim, the target's extent,
the clear-sky rectangle), the target's segmentation, rim contamination, running mean/std,
section 6 noise, and a measured SNR against the model's expected reading (model_agreement)."""
