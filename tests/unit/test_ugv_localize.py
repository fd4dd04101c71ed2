import numpy as np
import pytest

from uvteam.geo import LocalFrame
from uvteam.ugv_localize import focal_px_from_reference, localize_people

FRAME = LocalFrame(31.4850, -111.5440, 1300.0)


def test_focal_hand_worked():
    # a 1.75 m person 10 m away is 140 px tall: f = 10 * 140 / 1.75 = 800 px
    assert focal_px_from_reference(10.0, 140.0, 1.75) == pytest.approx(800.0)


@pytest.mark.parametrize("args", [(0.0, 140.0, 1.75), (10.0, -1.0, 1.75), (10.0, 140.0, float("nan"))])
def test_focal_rejects_bad_input(args):
    with pytest.raises(ValueError):
        focal_px_from_reference(*args)


def test_triangle_similarity_hand_worked():
    # UGV at the origin heading 90 deg (east). f = 800 px, image centre cx = 320.
    # Person A: 80 px tall, feet at x = 320  -> D = 800*1.7/80 = 17 m straight ahead: (17, 0)
    # Person B: 160 px tall, feet at x = 1120 -> D = 8.5 m, bearing 90 + atan(800/800) = 135 deg:
    #           (8.5 sin 135, 8.5 cos 135) = (6.0104, -6.0104)
    lat0, lon0 = FRAME.ground_to_wgs84(0.0, 0.0)
    fix = localize_people(FRAME, lat0, lon0, 90.0, 800.0, 320.0, [320.0, 1120.0], [80.0, 160.0], 1.7)
    np.testing.assert_allclose(fix.distance_m, [17.0, 8.5])
    np.testing.assert_allclose(fix.bearing_deg, [90.0, 135.0])
    np.testing.assert_allclose(fix.east_m, [17.0, 6.0104076], atol=1e-6)
    np.testing.assert_allclose(fix.north_m, [0.0, -6.0104076], atol=1e-6)
    assert fix.centre_east_m == pytest.approx((17.0 + 6.0104076) / 2, abs=1e-6)
    e, n = FRAME.wgs84_to_ground(fix.lat_deg, fix.lon_deg)
    np.testing.assert_allclose(e, fix.east_m, atol=1e-4)
    assert fix.spread_m > 0


def test_no_people_gives_nan_centre_not_crash():
    fix = localize_people(FRAME, 31.485, -111.544, 0.0, 800.0, 320.0, [], [], 1.7)
    assert len(fix.east_m) == 0 and np.isnan(fix.centre_lat_deg)


def test_invalid_heights_are_dropped():
    fix = localize_people(FRAME, 31.485, -111.544, 0.0, 800.0, 320.0, [300.0, 310.0], [0.0, 100.0], 1.7)
    assert len(fix.distance_m) == 1 and fix.distance_m[0] == pytest.approx(13.6)
