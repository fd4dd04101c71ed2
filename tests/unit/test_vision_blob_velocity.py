"""A blob's walkers' velocity from corners on them (step 8 of the motion detector)."""

import cv2
import numpy as np
import pytest

from uvteam.blobs import Blobs
from uvteam.vision.blob_velocity import VelocityConfig, walkers_velocity
from uvteam.vision.motion import MotionConfig, MotionDetector


def texture(h, w, seed, sigma=2.0):
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.integers(0, 255, (h, w)).astype(np.uint8), (0, 0), sigma)
    return cv2.normalize(t, None, 0, 255, cv2.NORM_MINMAX)


# walkers from above: blobs of their clothes' colour, each its own
PATCHES = [np.full((12, 12), v, np.uint8) for v in (250, 10, 230, 30, 210, 50)]


def scene(k: int, walkers_at, ground, pan_px=(5.0, 3.0)):
    """Frame ``k``: the camera panned by ``k * pan_px`` over the ground, textured walkers on top."""
    M = np.float32([[1, 0, -pan_px[0] * k], [0, 1, -pan_px[1] * k]])
    img = cv2.warpAffine(ground, M, (640, 480))
    for (x, y), patch in zip(walkers_at, PATCHES):
        xi, yi = int(round(x - pan_px[0] * k)), int(round(y - pan_px[1] * k))
        img[yi - 6:yi + 6, xi - 6:xi + 6] = patch
    return img, M


def test_walkers_moving_against_a_panning_camera_measure_their_own_velocity():
    ground = texture(600, 800, 1)
    starts = [(300 + 40 * i, 200 + 25 * (i % 3)) for i in range(5)]
    walk = np.array([4.0, -2.0])   # px a frame against the ground
    old, M0 = scene(0, starts, ground)
    new, M5 = scene(5, [(x + 5 * walk[0], y + 5 * walk[1]) for x, y in starts], ground)
    H = np.vstack([M5, [0, 0, 1]]) @ np.linalg.inv(np.vstack([M0, [0, 0, 1]]))   # old's ground onto new's
    box = np.array([[280.0, 165.0, 490.0, 250.0]])   # round the walkers in the new frame
    v, sigma = walkers_velocity(old, new, H, box, 0.5)
    assert sigma[0] > 0
    np.testing.assert_allclose(v[0], walk * 5 / 0.5, atol=0.5)   # 40, -20 px/s
    # the ground alone moves with the camera: nothing measured
    v0, s0 = walkers_velocity(old, scene(5, [], ground)[0], H, np.array([[100.0, 100.0, 200.0, 200.0]]), 0.5)
    assert s0[0] == 0 and not v0.any()


def test_a_camera_motion_the_fits_leave_a_pixel_off_is_corrected_by_the_still_ground_round_the_walkers():
    ground = texture(600, 800, 2)
    starts = [(320, 240), (360, 250), (335, 275)]
    old, M0 = scene(0, starts, ground)
    new, M5 = scene(5, [(x + 15, y) for x, y in starts], ground)
    H = np.vstack([M5, [0, 0, 1]]) @ np.linalg.inv(np.vstack([M0, [0, 0, 1]]))
    H_off = np.array([[1, 0, 1.2], [0, 1, -0.8], [0, 0, 1]]) @ H      # chained fits off by (1.2, -0.8) px
    box = np.array([[300.0, 210.0, 400.0, 300.0]])
    v, _ = walkers_velocity(old, new, H_off, box, 0.5)
    np.testing.assert_allclose(v[0], (30.0, 0.0), atol=0.6)


@pytest.mark.parametrize("starts", [[(300 + 40 * i, 200 + 25 * (i % 3)) for i in range(5)],
                                    [(20 + 30 * i, 440 + 10 * (i % 2)) for i in range(4)]],
                         ids=["mid-frame", "at-the-edge"])
def test_lucas_kanade_on_crops_gives_the_whole_frames_answer(monkeypatch, starts):
    """Step 8 follows corners on crops round each box and its place in the older frame; with crops as large as
    the frames (the whole-frame pyramids it saves) the velocity is the same, in mid-frame and where the crop is
    cut by the frame's edge."""
    import uvteam.vision.blob_velocity as bv
    ground = texture(600, 800, 4)
    walk = np.array([3.0, -1.5])
    old, M0 = scene(0, starts, ground)
    new, M4 = scene(4, [(x + 4 * walk[0], y + 4 * walk[1]) for x, y in starts], ground)
    H = np.vstack([M4, [0, 0, 1]]) @ np.linalg.inv(np.vstack([M0, [0, 0, 1]]))
    xy = np.array([(x + 4 * walk[0] - 20, y + 4 * walk[1] - 12) for x, y in starts])
    box = np.array([[*(xy.min(0) - 15), *(xy.max(0) + 15)]])
    cropped = walkers_velocity(old, new, H, box, 0.4)
    monkeypatch.setattr(bv, "_lk_reach_px", lambda cfg: 100_000)
    whole = walkers_velocity(old, new, H, box, 0.4)
    assert cropped[1][0] > 0 and whole[1][0] > 0
    np.testing.assert_allclose(cropped[0], whole[0], rtol=0.01, atol=0.05)
    np.testing.assert_allclose(cropped[0][0], walk / 0.1, atol=1.0)


def test_the_velocity_settings_are_checked():
    with pytest.raises(ValueError):
        VelocityConfig(back_px=0.0)
    with pytest.raises(ValueError):
        MotionConfig(velocity_lag_s=3.0)


def test_the_detector_measures_a_crowd_s_velocity_and_no_vehicle_s():
    """Through MotionDetector.update: the crowd blob gets the walkers' velocity from about velocity_lag_s
    back; the carved vehicle none; before that much time is kept, none either."""
    ground = texture(600, 800, 3)
    det = MotionDetector(MotionConfig(velocity_lag_s=0.5, min_area_px=100.0, speckle="neighbours"))
    walkers = [(250 + 30 * i, 220 + 20 * (i % 2)) for i in range(4)]
    vehicle = (500.0, 380.0)
    step = np.array([3.0, 2.0])
    seen = []
    for k in range(10):
        at = [(x + step[0] * k, y + step[1] * k) for x, y in walkers]
        img, M = scene(k, at, ground, pan_px=(4.0, -2.0))
        vx, vy = vehicle[0] + 5 * k - 4.0 * k, vehicle[1] + 2.0 * k
        cv2.rectangle(img, (int(vx) - 8, int(vy) - 5), (int(vx) + 8, int(vy) + 5), 30, -1)
        r = det.update(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR), 0.1 * k, np.array([[vx, vy]]), 14.0, ("u1",))
        seen.append(r)
    assert sum(int((r.carved < 0).sum()) for r in seen[5:]) >= 4    # the crowd was seen
    for k, r in enumerate(seen):
        crowds = np.flatnonzero(r.carved < 0)
        if not len(r):
            continue
        assert len(r.blobs.v_px_s) == len(r)
        for i in np.flatnonzero(r.carved >= 0):
            assert r.blobs.velocity_of(int(i)) is None
        for i in crowds:
            got = r.blobs.velocity_of(int(i))
            if k < 5:
                assert got is None, f"frame {k}: measured before 0.5 s were kept"
            else:
                assert got is not None, f"frame {k}: not measured"
                np.testing.assert_allclose(got[0], step / 0.1, atol=3.0)   # 10 %: four walkers


def test_blobs_carry_their_velocities_through_selection_and_relabelling():
    b = Blobs(np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([[0.0, 0, 2, 4], [2, 3, 4, 5]]), np.array([5.0, 6.0]),
              ("red", ""), np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([0.4, 0.0]))
    assert b[np.array([1])].velocity_of(0) is None
    got = b.relabel({"red": "u1"})[np.array([True, False])].velocity_of(0)
    assert got is not None and got[1] == 0.4 and tuple(got[0]) == (1.0, 0.0)
    with pytest.raises(ValueError):
        Blobs(b.xy_px, b.xyxy_px, b.area_px, b.ugv, np.zeros((1, 2)), np.zeros(1))
    with pytest.raises(ValueError):
        Blobs(b.xy_px, b.xyxy_px, b.area_px, b.ugv, np.zeros((2, 2)), np.array([0.1, -1.0]))


def test_a_vehicle_driving_through_a_crowd_is_not_the_crowd_s_velocity():
    """A UGV's roof has the sharpest corners in view: driving through the crowd's box, its corners are off."""
    ground = texture(600, 800, 3)
    walkers = [(250 + 30 * i, 220 + 20 * (i % 2)) for i in range(4)]
    step = np.array([3.0, 2.0])
    roof = np.zeros((14, 22), np.uint8)
    roof[::4, :] = 255
    roof[:, ::5] = 255
    det = MotionDetector(MotionConfig(velocity_lag_s=0.5, min_area_px=100.0, speckle="neighbours"))
    for k in range(10):
        at = [(x + step[0] * k, y + step[1] * k) for x, y in walkers]
        img, _ = scene(k, at, ground, pan_px=(4.0, -2.0))
        vx, vy = 262.0 + 4.0 * k, 226.0 + 4.0 * k      # 80, 20 px/s against the ground, amid the walkers
        img[int(vy) - 7:int(vy) + 7, int(vx) - 11:int(vx) + 11] = roof
        r = det.update(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR), 0.1 * k, np.array([[vx, vy]]), 16.0, ("u1",))
    crowds = np.flatnonzero(r.carved < 0)
    assert len(crowds) == 1
    x0, y0, x1, y1 = r.blobs.xyxy_px[crowds[0]]
    assert x0 < vx < x1 and y0 < vy < y1      # the vehicle is in the crowd's box
    got = r.blobs.velocity_of(int(crowds[0]))
    assert got is not None
    np.testing.assert_allclose(got[0], step / 0.1, atol=2.0)


@pytest.mark.parametrize("alt_m, lag_s", [(50.0, 0.158), (60.0, 0.190), (120.0, 0.380), (200.0, 0.5)])
def test_the_uav_pipeline_measures_over_no_longer_than_a_fast_walker_stays_within_reach(alt_m, lag_s):
    # Lucas-Kanade, searched from where the ground was, finds a walker within about 8 px: paper-fig7-alt50's crowd,
    # 3.1 m/s at 50 m (25 px in 0.5 s), was measured at 0.27-0.34 of its speed over 0.5 s; over 0.16 s, 0.94-0.97
    from uvteam.camera import PinholeCamera
    from uvteam.vision.uav import UavVision, UavVisionConfig

    vis = UavVision(UavVisionConfig(focal_px=PinholeCamera(1280, 720, 78.0).focal_px, colors=("red",)))
    vis.update(np.zeros((720, 1280, 3), np.uint8), 1.0, alt_m)
    assert vis.motion_config.velocity_lag_s == pytest.approx(lag_s, abs=0.002)
