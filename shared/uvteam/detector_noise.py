"""What each UAV detector's reported image positions are worth: the 1-sigma noise per axis that the
detector declares with its detections (:class:`uvteam.messages.Detections` ``sigma_*``) and the
localizer propagates into every crowd's 95 % radius. Declared once per detector.

- ``PIXEL_SIGMA_M``: the pixel pipeline (:mod:`uvteam.vision.uav`), in ground metres per axis (so it
  holds at any altitude; :func:`pixel_pipeline_noise` turns it into pixels for a camera and height),
  measured on rendered frames against the true positions (``uvteam experiment --detector pixels``):
  roof-label centres 0.02 m; a UGV's motion-blob centre 0.2 m; a crowd's blob centre is off its
  members' centroid by an offset each crowd keeps for seconds (unequal contrast and size of the walkers
  and their shadows weight the moving pixels: 0.2-1.1 m, in any direction, one crowd to the next;
  mean over 1 s) plus 0.2-1.0 m that changes from frame to frame. The pipeline declares the first,
  0.52 m per axis: its RMS over the worlds it was tuned on, seeds 2-3 (paper-fig7-alt200 0.45 / 0.45,
  paper-fig8-lm6 0.33 / 0.22, field-alt100-lm6 0.43 / 0.74, real-alt60-lm6 0.41 / 0.82, real-alt120-lm6
  0.46 / 0.64 m; docs/radius_decomposition.py, 2026-12-03 at 470d8d1, once a crowd's strays pull its
  centre, :mod:`uvteam.vision.motion` step 7). Before: 0.72 m when first measured (2026-12-02), 0.63 m
  once the detector saw walkers of little contrast (at 8a59b0b), 0.62 m once the blob's centre came
  from its motion history (at 613a079; the value stood). Where a walker is two or three pixels the
  offset grows: at 200 m over real imagery (0.253 m a pixel) walkers on dark ground drop out of the
  blob, and seeds 2-3 kept 0.52 / 0.95 m (RMS 0.77 m = 3.0 px; seeds 1, 100-103 0.71-1.34 m), where at
  60 and 120 m seeds 1-3 kept 0.37-0.70 m. So the declared part is never under
  ``CROWD_BLOB_MIN_PX`` image pixels, which with a 1280-pixel 78 deg camera first exceeds 0.52 m above
  137 m (docs/results-worlds.md, session 48). It does not average out
  over frames, and nothing one view shows (ground texture, the compensated difference's noise, the
  blob's area or box) was found to tell a crowd's offset, so the value declared is the worst ground's;
  what a crowd's estimates do over seconds does tell it (a blob whose centre scatters little about its
  walk keeps a small offset too), and :mod:`uvteam.crowds` narrows the declared part by it. The second
  part is left to be measured in flight (``crowd_blob_frame_px`` 0: :mod:`uvteam.crowds` widens each
  crowd's radius by the scatter of its own estimates within each second; what they do over longer is
  the first part changing, and widens the radius only beyond it).
- ``SENSOR_MODEL_NOISE``: the simulator's sensor model, which stands in for a detector when no pixels
  are processed; it draws its noise from this table, in image pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["CROWD_BLOB_MIN_PX", "DetectorNoise", "PIXEL_SIGMA_M", "SENSOR_MODEL_NOISE", "pixel_pipeline_noise"]


@dataclass(frozen=True, slots=True)
class DetectorNoise:
    """1-sigma per axis, pixels: a roof label's centre, a UGV's motion-blob centre, a crowd's blob centre,
    and of the last the part that changes from frame to frame (None: all of it)."""

    color_px: float
    ugv_blob_px: float
    crowd_blob_px: float
    crowd_blob_frame_px: float | None = None


PIXEL_SIGMA_M = {"color": 0.03, "ugv_blob": 0.25, "crowd_blob": 0.52}
CROWD_BLOB_MIN_PX = 3.0   # ... and never under this many image pixels: walkers of two pixels (200 m)
SENSOR_MODEL_NOISE = DetectorNoise(color_px=0.5, ugv_blob_px=1.0, crowd_blob_px=1.5)   # white: all per frame


def pixel_pipeline_noise(alt_agl_m: float, focal_px: float) -> DetectorNoise:
    """The pixel pipeline's noise in pixels for a camera of ``focal_px`` at ``alt_agl_m`` above ground."""
    if not (alt_agl_m > 0 and focal_px > 0):
        raise ValueError(f"alt_agl_m and focal_px must be > 0, got {alt_agl_m}, {focal_px}")
    px_per_m = focal_px / alt_agl_m
    return DetectorNoise(PIXEL_SIGMA_M["color"] * px_per_m, PIXEL_SIGMA_M["ugv_blob"] * px_per_m,
                         max(PIXEL_SIGMA_M["crowd_blob"] * px_per_m, CROWD_BLOB_MIN_PX), crowd_blob_frame_px=0.0)
