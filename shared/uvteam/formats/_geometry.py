"""Small geometry and time helpers the converters share (private)."""

from __future__ import annotations

import math
from datetime import datetime, timezone

import numpy as np

from ..geo import LocalFrame
from ..mgrs import latlon_to_mgrs

# A 2-D isotropic Gaussian with per-axis sigma holds P(r <= k sigma) = 1 - exp(-k^2 / 2) within radius
# k sigma (the radius is Rayleigh distributed), so its 95 % circle has k = sqrt(2 ln 20) = 2.4477.
SIGMA_PER_R95 = 1.0 / math.sqrt(2.0 * math.log(20.0))      # 0.40853


def sigma_from_radius95(radius95_m: float) -> float:
    """The circular 1-sigma (the per-axis sigma of the isotropic 2-D Gaussian) whose 95 % circle has
    radius ``radius95_m``: radius95 / sqrt(2 ln 20) = 0.4085 radius95. That circle holds 39.3 % of the
    distribution. uvteam's radius95_m is the 95 % circle of the full covariance, so for an elongated
    error the major-axis sigma is up to radius95 / 1.960 (20 % more than this)."""
    return float(radius95_m) * SIGMA_PER_R95


def course_speed(v_east_m_s: float | None, v_north_m_s: float | None,
                 min_speed_m_s: float = 0.1) -> tuple[float | None, float | None]:
    """(course_deg clockwise from north in [0, 360) or None when slower than ``min_speed_m_s``, speed_m_s);
    (None, None) when the velocity is unknown."""
    if v_east_m_s is None or v_north_m_s is None:
        return None, None
    speed = math.hypot(v_east_m_s, v_north_m_s)
    if speed < min_speed_m_s:
        return None, speed
    return math.degrees(math.atan2(v_east_m_s, v_north_m_s)) % 360.0, speed


def iso8601(stamp_s: float) -> str:
    """UNIX seconds -> '2026-12-01T10:00:00.250Z' (UTC, milliseconds)."""
    t = datetime.fromtimestamp(stamp_s, tz=timezone.utc)
    return t.strftime("%Y-%m-%dT%H:%M:%S.") + f"{t.microsecond // 1000:03d}Z"


def mgrs_or_empty(lat_deg: float, lon_deg: float, precision: int = 5) -> str:
    """The MGRS reference, or "" where MGRS needs UPS (beyond -80/84 degrees), which is not written."""
    try:
        return latlon_to_mgrs(lat_deg, lon_deg, precision)
    except ValueError:
        return ""


def circle_ring(lat_deg: float, lon_deg: float, radius_m: float, n: int = 36) -> list[tuple[float, float]]:
    """A closed counter-clockwise ring of (lon_deg, lat_deg) at ``radius_m`` on the tangent plane at the
    centre (uvteam.geo, WGS84): n vertices, first repeated last. Empty for a radius <= 0."""
    if not radius_m > 0.0:
        return []
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)          # counter-clockwise from east
    lat, lon = LocalFrame(lat_deg, lon_deg).ground_to_wgs84(radius_m * np.cos(a), radius_m * np.sin(a))
    ring = [(float(x), float(y)) for x, y in zip(lon, lat)]
    return ring + [ring[0]]


def hull_ring(lats_deg, lons_deg) -> list[tuple[float, float]]:
    """The convex hull of the points as a closed counter-clockwise ring of (lon_deg, lat_deg) (Andrew's
    monotone chain); empty when the points span no area (fewer than 3 distinct, or all on a line)."""
    pts = sorted({(float(x), float(y)) for x, y in zip(lons_deg, lats_deg)})
    if len(pts) < 3:
        return []

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0.0:
            lower.pop()
        lower.append(p)
    upper: list = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0.0:
            upper.pop()
        upper.append(p)
    hull = lower[:-1] + upper[:-1]
    if len(hull) < 3:
        return []
    return hull + [hull[0]]
