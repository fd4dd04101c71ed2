import numpy as np
import pymap3d
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uvteam.geo import LocalFrame, ecef_to_geodetic, geodetic_to_ecef

SASABE = LocalFrame(31.4850, -111.5440, 1300.0)


@pytest.mark.parametrize(
    "origin, east_m, north_m, up_m",
    [
        ((31.4850, -111.5440, 1300.0), 0.0, 0.0, 0.0),          # the origin itself
        ((31.4850, -111.5440, 1300.0), 5000.0, 0.0, 0.0),       # 5 km east
        ((31.4850, -111.5440, 1300.0), -3000.0, 4000.0, 12.0),  # 5 km north-west, above
        ((0.0, 0.0, 0.0), 1234.5, -4321.0, -3.0),               # equator / Greenwich
        ((78.2, 15.6, 10.0), 3500.0, 3500.0, 0.0),              # Svalbard, high latitude
        ((-33.9, 151.2, 50.0), -4999.0, 10.0, 100.0),           # southern / eastern hemisphere
    ],
)
def test_enu_against_pymap3d(origin, east_m, north_m, up_m):
    frame = LocalFrame(*origin)
    lat, lon, h = frame.enu_to_wgs84(east_m, north_m, up_m)
    lat_r, lon_r, h_r = pymap3d.enu2geodetic(east_m, north_m, up_m, *origin)
    # compare in metres: 1 deg of latitude ~ 111 km
    assert abs(lat - lat_r) * 111_000 < 1e-3
    assert abs(lon - lon_r) * 111_000 * np.cos(np.radians(lat_r)) < 1e-3
    assert abs(h - h_r) < 1e-3
    e, n, u = frame.wgs84_to_enu(lat_r, lon_r, h_r)
    e_r, n_r, u_r = pymap3d.geodetic2enu(lat_r, lon_r, h_r, *origin)
    assert max(abs(e - e_r), abs(n - n_r), abs(u - u_r)) < 1e-3


@settings(max_examples=200, deadline=None)
@given(st.floats(-80, 80), st.floats(-180, 180), st.floats(-5000, 5000), st.floats(-5000, 5000),
       st.floats(-100, 500))
def test_enu_round_trip(lat0, lon0, e, n, u):
    f = LocalFrame(lat0, lon0, 100.0)
    lat, lon, h = f.enu_to_wgs84(e, n, u)
    e2, n2, u2 = f.wgs84_to_enu(lat, lon, h)
    assert abs(e2 - e) < 1e-6 and abs(n2 - n) < 1e-6 and abs(u2 - u) < 1e-6


def test_vectorised_shapes():
    e = np.linspace(-1000, 1000, 7)
    lat, lon = SASABE.ground_to_wgs84(e, e[::-1])
    assert lat.shape == (7,) and lon.shape == (7,)
    e2, n2 = SASABE.wgs84_to_ground(lat, lon)
    np.testing.assert_allclose(e2, e, atol=1e-4)
    np.testing.assert_allclose(n2, e[::-1], atol=1e-4)


def test_ecef_round_trip_extremes():
    for lat, lon, h in [(90.0, 0.0, 0.0), (-89.999, 45.0, 8000.0), (0.0, 180.0, -400.0)]:
        la, lo, hh = ecef_to_geodetic(*geodetic_to_ecef(lat, lon, h))
        assert abs(la - lat) < 1e-9 and abs(hh - h) < 1e-6
        if abs(lat) < 90:
            assert abs(((lo - lon) + 180) % 360 - 180) < 1e-9


def test_paper_constant_is_worse_than_wgs84():
    # The paper converts with 111 320 m per degree on both axes; at 31.5 deg N that puts a point
    # 1 km east about 150 m off. Our conversion is exact to the millimetre.
    lat, lon = SASABE.ground_to_wgs84(1000.0, 0.0)
    paper_east = (lon - SASABE.origin_lon_deg) * 111_320.0
    assert abs(paper_east - 1000.0) > 100.0
    e, _ = SASABE.wgs84_to_ground(lat, lon)
    assert abs(e - 1000.0) < 1e-3


@pytest.mark.parametrize("lat, lon", [(91.0, 0.0), (0.0, 181.0), (float("nan"), 0.0)])
def test_bad_origin_rejected(lat, lon):
    with pytest.raises(ValueError):
        LocalFrame(lat, lon)
