"""uvteam.mgrs against an independent implementation: the `mgrs` package (NGA's GeoTrans C code)."""

import math
import random

import pytest

from uvteam.mgrs import _ups, format_mgrs, latlon_to_mgrs, latlon_to_utm, utm_zone

ref_mgrs = pytest.importorskip("mgrs", reason="the reference implementation (pip install mgrs, in the test extras)")


def _ref(lat_deg: float, lon_deg: float, precision: int) -> str:
    s = ref_mgrs.MGRS().toMGRS(lat_deg, lon_deg, MGRSPrecision=precision)
    s = s.decode() if isinstance(s, bytes) else s
    return s[1:] if s[:2].isdigit() and s[0] == "0" else s   # GeoTrans pads the zone to two digits


@pytest.mark.parametrize("lat_deg, lon_deg, precision, expected", [
    (31.485, -111.544, 5, "12RVV4833083482"),      # the demo's origin near Sasabe, Arizona
    (21.309444, -157.916861, 5, "4QFJ1234056781"),  # zone < 10: no leading zero
    (38.8895, -77.0352, 5, "18SUJ2348606483"),     # Washington monument
    (-33.8568, 151.2153, 5, "56HLH3490052288"),    # southern hemisphere: 10 000 km false northing
    (0.0, 0.0, 5, "31NAA6602100000"),              # equator at the prime meridian: band N, northing 0
    (-0.00001, 10.0, 4, "32MPE11289999"),          # just south of the equator: band M, northing 9 999 9xx
    (60.0, 4.0, 5, "32VKM2128861953"),             # Norway: 32V is widened west to 3 E
    (60.0, 2.9, 5, "31VDG9442251415"),             # ... and 31V ends at 3 E
    (78.0, 8.9, 3, "31XFG367652"),                 # Svalbard: 31X up to 9 E
    (78.0, 9.1, 3, "33XUG632652"),                 # 33X from 9 E (no 32X)
    (78.0, 33.1, 3, "37XCG632652"),                # 37X from 33 E
    (78.0, 42.1, 3, "38XMM327600"),                # back to the regular zones at 42 E
    (84.0, 10.0, 2, "33XVP4130"),                  # 84 N itself is still UTM, band X
    (-80.0, 10.0, 2, "32CNS1918"),                 # 80 S itself is still UTM, band C
    (-80.0001, 10.0, 2, "BBY9396"),                # south of 80 S: UPS, zone B (east)
    (86.0, 90.0, 2, "ZGH4400"),                    # north of 84 N: UPS, zone Z (east)
    (-85.0, -90.0, 2, "ASN4400"),                  # UPS south, zone A (west)
    (90.0, 0.0, 0, "ZAH"),                         # the north pole, 100 km square only
    (-90.0, 179.0, 0, "BAN"),                      # the south pole, any longitude
    (31.485, 180.0, 3, "1RBQ150872"),              # 180 E is 180 W: zone 1
    (31.485, -180.0, 3, "1RBQ150872"),             # the same point
    (51.4778, -0.0015, 5, "30UYC0821307224"),      # Greenwich, just west of the prime meridian
    (-54.8, -68.3, 1, "19FEV42"),                  # 10 km precision
])
def test_known_references(lat_deg, lon_deg, precision, expected):
    assert latlon_to_mgrs(lat_deg, lon_deg, precision) == expected
    assert _ref(lat_deg, lon_deg, precision) == expected


def test_agrees_with_geotrans_everywhere():
    """Random points over the globe at every precision. GeoTrans rounds the last digit where the
    standard truncates, so a point is compared only where both read the same cell: its easting and
    northing lie in the lower half of their cell (1 cm margin), about a quarter of the points."""
    rng = random.Random(14)
    compared = 0
    for _ in range(12_000):
        lat, lon, precision = rng.uniform(-90, 90), rng.uniform(-180, 180), rng.randint(0, 5)
        e, n = latlon_to_utm(lat, lon)[2:] if -80 <= lat <= 84 else _ups(lat, lon)
        cell_m = 10 ** (5 - precision)
        if not all(0.01 < v % cell_m < cell_m / 2 - 0.01 for v in (e, n)):
            continue
        compared += 1
        assert latlon_to_mgrs(lat, lon, precision) == _ref(lat, lon, precision), (lat, lon, precision)
    assert compared > 2500


def test_truncates_to_the_cell_corner():
    # 0.9 m east of a 1 m line is still that line's cell; GeoTrans would round up
    zone, _, e, n = latlon_to_utm(31.485, -111.544)
    assert latlon_to_mgrs(31.485, -111.544, 5)[-10:] == f"{int(e) % 100000:05d}{int(n) % 100000:05d}"
    assert latlon_to_mgrs(31.485, -111.544, 2) == "12RVV4883"


def test_utm_against_the_textbook_point():
    # a zone's central meridian maps to easting 500 000 m, the equator to northing 0, exactly
    assert latlon_to_utm(0.0, 3.0) == (31, True, 500000.0, 0.0)
    z, north, e, n = latlon_to_utm(-45.0, 177.0)
    assert (z, north, e) == (60, False, 500000.0)
    # along the central meridian northing is k0 times the meridian arc: 4 984 944.378 m to 45 deg on WGS84
    assert math.isclose(10_000_000.0 - n, 4984944.378 * 0.9996, abs_tol=1e-3)


@pytest.mark.parametrize("lat_deg, lon_deg, zone", [
    (31.485, -111.544, 12),   # Arizona
    (60.0, 3.0, 32),          # Norway's exception starts at 3 E
    (55.99, 3.5, 31),         # just south of band V: regular
    (64.0, 5.0, 31),          # band W: regular
    (80.0, 8.99, 31),         # Svalbard
    (80.0, 20.99, 33),
    (80.0, 32.99, 35),
    (80.0, 41.99, 37),
    (0.0, 180.0, 1),          # 180 E counts as 180 W
    (0.0, 179.99, 60),
])
def test_utm_zone(lat_deg, lon_deg, zone):
    assert utm_zone(lat_deg, lon_deg) == zone


@pytest.mark.parametrize("args, word", [
    ((91.0, 0.0), "lat_deg"),             # beyond the pole
    ((float("nan"), 0.0), "lat_deg"),     # NaN never becomes a reference
    ((0.0, 180.5), "lon_deg"),            # beyond the antimeridian
    ((0.0, float("inf")), "lon_deg"),     # infinite
    ((0.0, 0.0, 6), "precision"),         # finer than 1 m does not exist in MGRS
    ((0.0, 0.0, -1), "precision"),        # negative
    ((0.0, 0.0, 2.0), "precision"),       # a float is not a digit count
    ((True, 0.0), "lat_deg"),             # a bool is not a latitude
    (("31", 0.0), "lat_deg"),             # nor is a string
])
def test_bad_arguments_name_the_argument(args, word):
    with pytest.raises(ValueError, match=word):
        latlon_to_mgrs(*args)


@pytest.mark.parametrize("ref, spaced", [
    ("12RVV4833083482", "12R VV 48330 83482"),   # two-digit zone, 1 m
    ("4QFJ1234", "4Q FJ 12 34"),                  # one-digit zone, 100 m
    ("ZAH", "Z AH"),                              # polar, square only
    ("12R VV 48330 83482", "12R VV 48330 83482"), # already spaced: unchanged
])
def test_format_mgrs(ref, spaced):
    assert format_mgrs(ref) == spaced


def test_format_mgrs_rejects_odd_digits():
    with pytest.raises(ValueError, match="not an MGRS reference"):
        format_mgrs("12RVV123")
