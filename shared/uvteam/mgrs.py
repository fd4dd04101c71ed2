"""WGS84 latitude/longitude -> MGRS grid reference (Military Grid Reference System), pure Python.

    >>> latlon_to_mgrs(31.4850, -111.5440)
    '12RVV4833083482'
    >>> latlon_to_mgrs(31.4850, -111.5440, precision=3)      # 100 m
    '12RVV483834'

The string is grid zone + latitude band + 100 km square + ``precision`` easting digits + as many
northing digits, with no spaces and the zone number unpadded (``4QFJ...``, not ``04QFJ...``);
:func:`format_mgrs` spaces it for people (``12R VV 48330 83482``). Digits are TRUNCATED, as the
MGRS standard reads a reference: it names the south-west corner of the cell that holds the point
(the GeoTrans library behind the ``mgrs`` package rounds instead, so its last digit can be one more).

- Between 80 deg S and 84 deg N: UTM (transverse Mercator, scale 0.9996), zones of 6 deg with the
  Norway (32V) and Svalbard (31X, 33X, 35X, 37X) exceptions, latitude bands C..X of 8 deg (X is 12),
  100 km squares lettered by the AA scheme (column sets ABCDEFGH / JKLMNPQR / STUVWXYZ by zone,
  row letters A..V shifted by 5 in even zones).
- North of 84 deg N and south of 80 deg S: UPS (polar stereographic, scale 0.994, false easting and
  northing 2000 km), zones A/B (south) and Y/Z (north), west/east of the prime meridian.

The transverse Mercator uses Krüger's series to the sixth order in the third flattening (Karney 2011,
"Transverse Mercator with an accuracy of a few nanometers"): well under a millimetre inside a zone,
so a digit is only ever off where the point sits on a cell's edge to within floating-point noise.
The datum is WGS84 (a = 6378137 m, f = 1/298.257223563).
"""

from __future__ import annotations

import math

__all__ = ["latlon_to_mgrs", "format_mgrs", "utm_zone", "latlon_to_utm"]

_A_M = 6378137.0
_F = 1.0 / 298.257223563
_E = math.sqrt(_F * (2.0 - _F))              # first eccentricity
_N3 = _F / (2.0 - _F)                        # third flattening
_K0_UTM = 0.9996
_K0_UPS = 0.994

_BANDS = "CDEFGHJKLMNPQRSTUVWX"              # 8 deg bands from 80 S; X spans 72..84 N
_COLUMN_SETS = ("ABCDEFGH", "JKLMNPQR", "STUVWXYZ")
_ROWS = "ABCDEFGHJKLMNPQRSTUV"
# UPS: (columns west to east, first column's easting, rows south to north, first row's northing)
_UPS = {
    "A": ("JKLPQRSTUXYZ", 800_000.0, "ABCDEFGHJKLMNPQRSTUVWXYZ", 800_000.0),
    "B": ("ABCFGHJKLPQR", 2_000_000.0, "ABCDEFGHJKLMNPQRSTUVWXYZ", 800_000.0),
    "Y": ("JKLPQRSTUXYZ", 800_000.0, "ABCDEFGHJKLMNP", 1_300_000.0),
    "Z": ("ABCFGHJKLPQR", 2_000_000.0, "ABCDEFGHJKLMNP", 1_300_000.0),
}


def _kruger_alpha() -> tuple[float, ...]:
    n = _N3
    return (
        n / 2 - 2 * n**2 / 3 + 5 * n**3 / 16 + 41 * n**4 / 180 - 127 * n**5 / 288 + 7891 * n**6 / 37800,
        13 * n**2 / 48 - 3 * n**3 / 5 + 557 * n**4 / 1440 + 281 * n**5 / 630 - 1983433 * n**6 / 1935360,
        61 * n**3 / 240 - 103 * n**4 / 140 + 15061 * n**5 / 26880 + 167603 * n**6 / 181440,
        49561 * n**4 / 161280 - 179 * n**5 / 168 + 6601661 * n**6 / 7257600,
        34729 * n**5 / 80640 - 3418889 * n**6 / 1995840,
        212378941 * n**6 / 319334400,
    )


_ALPHA = _kruger_alpha()
_RECTIFYING_RADIUS_M = _A_M / (1 + _N3) * (1 + _N3**2 / 4 + _N3**4 / 64 + _N3**6 / 256)


def _check(lat_deg: float, lon_deg: float, precision: int = 5) -> None:
    if isinstance(lat_deg, bool) or not isinstance(lat_deg, (int, float)) or not math.isfinite(lat_deg) \
            or not -90.0 <= lat_deg <= 90.0:
        raise ValueError(f"lat_deg must be a finite latitude in [-90, 90], got {lat_deg!r}")
    if isinstance(lon_deg, bool) or not isinstance(lon_deg, (int, float)) or not math.isfinite(lon_deg) \
            or not -180.0 <= lon_deg <= 180.0:
        raise ValueError(f"lon_deg must be a finite longitude in [-180, 180], got {lon_deg!r}")
    if isinstance(precision, bool) or not isinstance(precision, int) or not 0 <= precision <= 5:
        raise ValueError(f"precision must be an integer digit count in 0..5 (100 km .. 1 m), got {precision!r}")


def _lon180(lon_deg: float) -> float:
    return -180.0 if lon_deg == 180.0 else lon_deg


def utm_zone(lat_deg: float, lon_deg: float) -> int:
    """The UTM zone number (1..60) MGRS uses at this point, Norway and Svalbard exceptions included."""
    _check(lat_deg, lon_deg)
    lon = _lon180(lon_deg)
    zone = min(int((lon + 180.0) // 6.0) + 1, 60)
    if 56.0 <= lat_deg < 64.0 and 3.0 <= lon < 12.0:
        return 32
    if 72.0 <= lat_deg <= 84.0 and 0.0 <= lon < 42.0:
        return 31 if lon < 9.0 else 33 if lon < 21.0 else 35 if lon < 33.0 else 37
    return zone


def latlon_to_utm(lat_deg: float, lon_deg: float, zone: int | None = None) -> tuple[int, bool, float, float]:
    """WGS84 -> UTM ``(zone, north, easting_m, northing_m)``; ``zone`` forces a zone (its neighbours
    are still accurate to well under a millimetre). Northing has the 10000 km false northing south."""
    _check(lat_deg, lon_deg)
    zone = utm_zone(lat_deg, lon_deg) if zone is None else zone
    if not 1 <= zone <= 60:
        raise ValueError(f"zone must be in 1..60, got {zone!r}")
    lam = math.radians(_lon180(lon_deg) - (6.0 * zone - 183.0))
    lam = (lam + math.pi) % (2.0 * math.pi) - math.pi
    phi = math.radians(lat_deg)
    sphi = math.sin(phi)
    # conformal latitude, as its tangent t
    t = math.sinh(math.atanh(sphi) - _E * math.atanh(_E * sphi))
    xi1 = math.atan2(t, math.cos(lam))
    eta1 = math.atanh(math.sin(lam) / math.sqrt(1.0 + t * t))
    xi, eta = xi1, eta1
    for j, a in enumerate(_ALPHA, start=1):
        xi += a * math.sin(2 * j * xi1) * math.cosh(2 * j * eta1)
        eta += a * math.cos(2 * j * xi1) * math.sinh(2 * j * eta1)
    easting = 500_000.0 + _K0_UTM * _RECTIFYING_RADIUS_M * eta
    northing = _K0_UTM * _RECTIFYING_RADIUS_M * xi
    north = lat_deg >= 0.0
    if not north:
        northing += 10_000_000.0
    return zone, north, easting, northing


def _ups(lat_deg: float, lon_deg: float) -> tuple[float, float]:
    """WGS84 -> UPS (easting_m, northing_m) about the nearer pole."""
    phi, lam = math.radians(abs(lat_deg)), math.radians(lon_deg)
    es = _E * math.sin(phi)
    t = math.tan(math.pi / 4 - phi / 2) / ((1 - es) / (1 + es)) ** (_E / 2)
    rho = 2.0 * _A_M * _K0_UPS * t / math.sqrt((1 + _E) ** (1 + _E) * (1 - _E) ** (1 - _E))
    north = lat_deg > 0.0
    return 2_000_000.0 + rho * math.sin(lam), 2_000_000.0 + (-rho if north else rho) * math.cos(lam)


def _digits(easting_m: float, northing_m: float, precision: int) -> str:
    if precision == 0:
        return ""
    cell_m = 10 ** (5 - precision)
    e = int(math.floor(easting_m % 100_000.0)) // cell_m
    n = int(math.floor(northing_m % 100_000.0)) // cell_m
    return f"{e:0{precision}d}{n:0{precision}d}"


def latlon_to_mgrs(lat_deg: float, lon_deg: float, precision: int = 5) -> str:
    """WGS84 ``(lat_deg, lon_deg)`` -> MGRS reference with ``precision`` digits per axis (5 = 1 m,
    4 = 10 m, ..., 0 = the 100 km square alone). Raises ValueError naming the bad argument."""
    _check(lat_deg, lon_deg, precision)
    if -80.0 <= lat_deg <= 84.0:
        zone, _north, easting, northing = latlon_to_utm(lat_deg, lon_deg)
        band = _BANDS[min(int((lat_deg + 80.0) // 8.0), len(_BANDS) - 1)]
        column = _COLUMN_SETS[(zone - 1) % 3][int(easting // 100_000.0) - 1]
        row = _ROWS[(int(northing // 100_000.0) + (5 if zone % 2 == 0 else 0)) % len(_ROWS)]
        return f"{zone}{band}{column}{row}{_digits(easting, northing, precision)}"
    easting, northing = _ups(lat_deg, lon_deg)
    west = easting < 2_000_000.0        # the easting decides, so that the pole itself is Z (or B)
    letter = ("Y" if west else "Z") if lat_deg > 0.0 else ("A" if west else "B")
    columns, e0, rows, n0 = _UPS[letter]
    column = columns[int((easting - e0) // 100_000.0)]
    row = rows[int((northing - n0) // 100_000.0)]
    return f"{letter}{column}{row}{_digits(easting, northing, precision)}"


def format_mgrs(ref: str) -> str:
    """An MGRS reference spaced for people: '12RVV4833083482' -> '12R VV 48330 83482'."""
    ref = ref.replace(" ", "")
    head = 3 if ref[:2].isdigit() else 2 if ref[:1].isdigit() else 1
    digits = ref[head + 2:]
    if len(digits) % 2 or (digits and not digits.isdigit()):
        raise ValueError(f"not an MGRS reference: {ref!r}")
    half = len(digits) // 2
    return " ".join(p for p in (ref[:head], ref[head:head + 2], digits[:half], digits[half:]) if p)
