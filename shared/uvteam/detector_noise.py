"""What each UAV detector's reported image positions are worth: the 1-sigma noise the localizer
propagates into every crowd's 95 % radius. One table per detector, declared once.

- ``PIXEL_SIGMA_M``: the pixel pipeline (:mod:`uvteam.vision.uav`), in ground metres per axis (so it
  holds at any altitude), measured on rendered frames against the true positions (paper-fig7-alt50,
  seed 1, ``uvteam experiment --detector pixels``): color-label centres 0.02 m; a UGV's motion-blob
  centre 0.2 m; a crowd's blob centre 0.57 m median off its members' centroid (unequal contrast of the
  walkers and their shadows), so 0.4 m per axis covers 95 %.
- ``SENSOR_MODEL_SIGMA_PX``: the simulator's sensor model, which stands in for a detector when no
  pixels are processed; it draws its noise from this table, in image pixels.
"""

from __future__ import annotations

__all__ = ["PIXEL_SIGMA_M", "SENSOR_MODEL_SIGMA_PX", "DETECTORS", "localizer_sigmas_px"]

PIXEL_SIGMA_M = {"color": 0.03, "ugv_blob": 0.25, "crowd_blob": 0.4}
SENSOR_MODEL_SIGMA_PX = {"color": 0.5, "ugv_blob": 1.0, "crowd_blob": 1.5}
DETECTORS = ("pixels", "sensor")


def localizer_sigmas_px(detector: str, image_coordinates: str, alt_agl_m: float, focal_px: float) -> tuple[float, float]:
    """(landmark, target) 1-sigma pixel noise for the localizer, for this detector and landmark source."""
    if detector not in DETECTORS:
        raise ValueError(f"detector must be one of {DETECTORS}, got {detector!r}")
    if image_coordinates not in ("motion", "color"):
        raise ValueError(f"image_coordinates must be 'motion' or 'color', got {image_coordinates!r}")
    lm = "ugv_blob" if image_coordinates == "motion" else "color"
    if detector == "sensor":
        return SENSOR_MODEL_SIGMA_PX[lm], SENSOR_MODEL_SIGMA_PX["crowd_blob"]
    if not (alt_agl_m > 0 and focal_px > 0):
        raise ValueError(f"alt_agl_m and focal_px must be > 0, got {alt_agl_m}, {focal_px}")
    px_per_m = focal_px / alt_agl_m
    return PIXEL_SIGMA_M[lm] * px_per_m, PIXEL_SIGMA_M["crowd_blob"] * px_per_m
