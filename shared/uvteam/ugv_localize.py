"""The paper's UGV rule: people seen by a UGV's forward camera -> ground positions by triangle similarity.

Calibration (once): a person of known height H_m standing D_m in front of the camera appears h_px
tall, so the focal length is f_px = D_m * h_px / H_m. Then for each detected person j of pixel height
h_j and horizontal deviation dev_j = x_feet_j - cx (positive to the right):

    D_j = f_px * H_mean_m / h_j                      distance along the ground
    bearing_j = heading_deg + atan(dev_j / f_px)     compass bearing, clockwise from north
    east_j  = east_ugv  + D_j sin(bearing_j)
    north_j = north_ugv + D_j cos(bearing_j)

Each person's feet point goes to lat/lon through the local ENU frame; the people seen are averaged
into a crowd-centre estimate with its spread.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geo import LocalFrame

__all__ = ["focal_px_from_reference", "PeopleFix", "localize_people"]


def focal_px_from_reference(distance_m: float, height_px: float, person_height_m: float) -> float:
    """f = D * h / H (pixels)."""
    for name, v in (("distance_m", distance_m), ("height_px", height_px), ("person_height_m", person_height_m)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {v}")
    return distance_m * height_px / person_height_m


@dataclass(frozen=True, slots=True)
class PeopleFix:
    east_m: np.ndarray          # (N,) feet points
    north_m: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    distance_m: np.ndarray
    bearing_deg: np.ndarray
    centre_lat_deg: float       # mean of the people seen (NaN when none)
    centre_lon_deg: float
    centre_east_m: float
    centre_north_m: float
    spread_m: float             # RMS distance of the people from their mean (0 for one person)


def localize_people(frame: LocalFrame, ugv_lat_deg: float, ugv_lon_deg: float, heading_deg: float,
                    focal_px: float, cx_px: float, feet_x_px, height_px,
                    person_height_m: float = 1.7) -> PeopleFix:
    feet_x = np.asarray(feet_x_px, float).reshape(-1)
    h = np.asarray(height_px, float).reshape(-1)
    ok = np.isfinite(feet_x) & np.isfinite(h) & (h > 0)
    feet_x, h = feet_x[ok], h[ok]
    e0, n0 = frame.wgs84_to_ground(ugv_lat_deg, ugv_lon_deg)
    d = focal_px * person_height_m / h
    bearing = heading_deg + np.degrees(np.arctan((feet_x - cx_px) / focal_px))
    b = np.radians(bearing)
    e = e0 + d * np.sin(b)
    n = n0 + d * np.cos(b)
    lat, lon = frame.ground_to_wgs84(e, n)
    if len(e):
        ce, cn = float(e.mean()), float(n.mean())
        spread = float(np.sqrt(((e - ce) ** 2 + (n - cn) ** 2).mean()))
        clat, clon = frame.ground_to_wgs84(ce, cn)
    else:
        ce = cn = spread = clat = clon = float("nan")
    return PeopleFix(e, n, np.atleast_1d(lat), np.atleast_1d(lon), d, np.mod(bearing, 360.0),
                     float(clat), float(clon), ce, cn, spread)
