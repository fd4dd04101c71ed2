"""What each UAV detector's reported image positions are worth: the 1-sigma noise per axis that the
detector declares with its detections (:class:`uvteam.messages.Detections` ``sigma_*``) and the
localizer propagates into every crowd's 95 % radius. Declared once per detector.

- ``PIXEL_SIGMA_M``: the pixel pipeline (:mod:`uvteam.vision.uav`), in ground metres per axis (so it
  holds at any altitude; :func:`pixel_pipeline_noise` turns it into pixels for a camera and height),
  measured on rendered frames against the true positions (paper-fig7-alt50, seed 1,
  ``uvteam experiment --detector pixels``): roof-label centres 0.02 m; a UGV's motion-blob centre
  0.2 m; a crowd's blob centre 0.57 m median off its members' centroid (unequal contrast of the
  walkers and their shadows), so 0.4 m per axis covers 95 %.
- ``SENSOR_MODEL_NOISE``: the simulator's sensor model, which stands in for a detector when no pixels
  are processed; it draws its noise from this table, in image pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DetectorNoise", "PIXEL_SIGMA_M", "SENSOR_MODEL_NOISE", "pixel_pipeline_noise"]


@dataclass(frozen=True, slots=True)
class DetectorNoise:
    """1-sigma per axis, pixels: a roof label's centre, a UGV's motion-blob centre, a crowd's blob centre."""

    color_px: float
    ugv_blob_px: float
    crowd_blob_px: float


PIXEL_SIGMA_M = {"color": 0.03, "ugv_blob": 0.25, "crowd_blob": 0.4}
SENSOR_MODEL_NOISE = DetectorNoise(color_px=0.5, ugv_blob_px=1.0, crowd_blob_px=1.5)


def pixel_pipeline_noise(alt_agl_m: float, focal_px: float) -> DetectorNoise:
    """The pixel pipeline's noise in pixels for a camera of ``focal_px`` at ``alt_agl_m`` above ground."""
    if not (alt_agl_m > 0 and focal_px > 0):
        raise ValueError(f"alt_agl_m and focal_px must be > 0, got {alt_agl_m}, {focal_px}")
    px_per_m = focal_px / alt_agl_m
    return DetectorNoise(PIXEL_SIGMA_M["color"] * px_per_m, PIXEL_SIGMA_M["ugv_blob"] * px_per_m,
                         PIXEL_SIGMA_M["crowd_blob"] * px_per_m)
