"""WGS84 latitude/longitude -> MGRS grid reference (the UTM part: latitudes -80 to 84 degrees).

    latlon_to_mgrs(31.4851, -111.5441)        -> "12RVV4832183493"   (1 m)
    latlon_to_mgrs(31.4851, -111.5441, 3)     -> "12RVV483834"       (100 m)

Steps: the UTM zone (6 degree zones with the Norway 32V and Svalbard 31X-37X exceptions), the
transverse Mercator projection on WGS84 by Krueger's series to fourth order in the third flattening n
(sub-millimetre inside a zone), the latitude band letter (C..X, 8 degrees each, X 12), the 100 km
square letters of the "AA" lettering scheme used with WGS84 (column sets A-H, J-R, S-Z by zone mod 3;
rows A-V without I and O, offset by 5 in even zones), and the digits truncated, not rounded, to the
precision (a reference names the square the point is in). The polar regions (UPS) are not covered:
they raise ValueError, as does anything outside the valid ranges.

Checked against the ``mgrs`` package (GeoTrans) in tests/unit/test_formats_mgrs.py.
"""

from __future__ import annotations

import math

__all__ = ["latlon_to_mgrs"]

_A_M = 6378137.0
_F = 1.0 / 298.257223563
_K0 = 0.9996
_N = _F / (2.0 - _F)                                   # third flattening
_E = math.sqrt(_F * (2.0 - _F))                        # first eccentricity
_A_RECT_M = _A_M / (1.0 + _N) * (1.0 + _N ** 2 / 4.0 + _N ** 4 / 64.0)   # rectifying radius
_ALPHA = (
    _N / 2.0 - 2.0 * _N ** 2 / 3.0 + 5.0 * _N ** 3 / 16.0 + 41.0 * _N ** 4 / 180.0,
    13.0 * _N ** 2 / 48.0 - 3.0 * _N ** 3 / 5.0 + 557.0 * _N ** 4 / 1440.0,
    61.0 * _N ** 3 / 240.0 - 103.0 * _N ** 4 / 140.0,
    49561.0 * _N ** 4 / 161280.0,
)
_BANDS = "CDEFGHJKLMNPQRSTUVWX"
_COLUMN_SETS = ("ABCDEFGH", "JKLMNPQR", "STUVWXYZ")
_ROWS = "ABCDEFGHJKLMNPQRSTUV"


def _zone(lat_deg: float, lon_deg: float) -> int:
    zone = int((lon_deg + 180.0) // 6.0) + 1
    if zone > 60:            # lon = 180 exactly
        zone = 60
    if 56.0 <= lat_deg < 64.0 and 3.0 <= lon_deg < 12.0:
        return 32
    if lat_deg >= 72.0 and 0.0 <= lon_deg < 42.0:
        return 31 if lon_deg < 9.0 else 33 if lon_deg < 21.0 else 35 if lon_deg < 33.0 else 37
    return zone


def _utm(lat_deg: float, lon_deg: float, zone: int) -> tuple[float, float]:
    """(easting_m, northing_m) in ``zone``, northing with the 10 000 km false northing south of the equator."""
    phi = math.radians(lat_deg)
    lam = math.radians(lon_deg - (zone * 6.0 - 183.0))
    t = math.sinh(math.atanh(math.sin(phi)) - _E * math.atanh(_E * math.sin(phi)))
    xi = math.atan2(t, math.cos(lam))
    eta = math.atanh(math.sin(lam) / math.sqrt(1.0 + t * t))
    e, n = eta, xi
    for j, a in enumerate(_ALPHA, start=1):
        e += a * math.cos(2 * j * xi) * math.sinh(2 * j * eta)
        n += a * math.sin(2 * j * xi) * math.cosh(2 * j * eta)
    easting = 500000.0 + _K0 * _A_RECT_M * e
    northing = _K0 * _A_RECT_M * n
    return easting, (northing + 10000000.0 if lat_deg < 0.0 else northing)


def latlon_to_mgrs(lat_deg: float, lon_deg: float, precision: int = 5) -> str:
    """WGS84 degrees -> MGRS string without spaces, e.g. "12RVV4832183493".

    ``precision`` is the digits per axis: 5 (1 m), 4 (10 m), 3 (100 m), 2 (1 km), 1 (10 km), 0 (100 km
    square only). Raises ValueError for a non-finite or out-of-range input, for latitudes outside
    [-80, 84] (the polar UPS regions), or for a precision outside 0-5."""
    if not (isinstance(precision, int) and 0 <= precision <= 5):
        raise ValueError(f"precision: expected an integer 0-5, got {precision!r}")
    if not (math.isfinite(lat_deg) and math.isfinite(lon_deg)):
        raise ValueError(f"lat_deg/lon_deg: expected finite numbers, got {lat_deg!r}, {lon_deg!r}")
    if not -80.0 <= lat_deg <= 84.0:
        raise ValueError(f"lat_deg: MGRS by UTM covers [-80, 84] (UPS beyond), got {lat_deg!r}")
    if not -180.0 <= lon_deg <= 180.0:
        raise ValueError(f"lon_deg: expected [-180, 180], got {lon_deg!r}")
    if lon_deg == 180.0:
        lon_deg = -180.0     # the same meridian, in zone 1
    zone = _zone(lat_deg, lon_deg)
    band = _BANDS[min(int((lat_deg + 80.0) // 8.0), len(_BANDS) - 1)]
    easting, northing = _utm(lat_deg, lon_deg, zone)
    col = _COLUMN_SETS[(zone - 1) % 3][int(easting // 100000.0) - 1]
    row = _ROWS[(int(northing // 100000.0) + (5 if zone % 2 == 0 else 0)) % 20]
    if precision == 0:
        return f"{zone:02d}{band}{col}{row}"
    div = 10.0 ** (5 - precision)
    e_digits = int(math.floor((easting % 100000.0) / div + 1e-9))
    n_digits = int(math.floor((northing % 100000.0) / div + 1e-9))
    return f"{zone:02d}{band}{col}{row}{e_digits:0{precision}d}{n_digits:0{precision}d}"
