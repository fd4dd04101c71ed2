"""The localizer step gives what the step gave before it was made faster, on every path it has: each
frame of many random scenes runs through the product (:mod:`uvteam.localizer`) and through a frozen
copy of the step as it was (tests/reference/localize_4d30179, commit 4d30179), and both must
agree to 1e-9 m. The recorded steps (test_localizer_golden.py) are real runs but take few paths (no
pose fallback, hold, suspect fit, labelled blobs, plans, greedy solver or color coordinates); these
scenes take all of them. (Equal means: every discrete outcome the same; values to 1e-9 m, or to 1e-10 of
their size beyond 1 km; transforms to 1e-12 as the recorded test.)"""

from dataclasses import replace

import numpy as np
import pytest

from uvteam import homography as hom_now
from uvteam import localizer as now
from uvteam.blobs import Blobs, Landmarks
from uvteam.camera import CameraPose, PinholeCamera, project
from uvteam.geo import LocalFrame
from uvteam.messages import CameraPoseReport
from uvteam.pose import pose_prior
from reference.localize_4d30179 import homography as hom_before
from reference.localize_4d30179 import localizer as before

CAM = PinholeCamera(1280, 720, 78.0)
FRAME = LocalFrame(31.4850, -111.5440)
ATOL_M = 1e-9
FAR_M, FAR_RTOL = 1000.0, 1e-10  # a wild fit puts crowds 100 km off, near its horizon: there round-off alone
                                 # is above 1e-9 m (before and after), so beyond 1 km the check is relative


def _close(got, want, where) -> None:
    got, want = np.asarray(got, float), np.asarray(want, float)
    tol = np.where(np.abs(want) < FAR_M, ATOL_M, FAR_RTOL * np.abs(want))
    same = (np.abs(got - want) <= tol) | (np.isnan(got) & np.isnan(want))
    assert same.all(), (where, got[~same], want[~same])


def _track(rng, en0, v, t_end):
    """Fixes up to ``t_end`` at a random rate, sometimes with velocity, latency, noise, a plan."""
    dt = rng.choice([0.1, 0.2, 0.25])
    ts = np.arange(t_end - rng.integers(1, 30 if rng.random() < 0.2 else 60) * dt, t_end + 1e-9, dt)
    en = en0 + np.outer(ts, v) + rng.normal(0, rng.choice([0.0, 0.3]), (len(ts), 2))
    sig = rng.choice([0.0, 0.01, 0.5, 1.5]) * np.ones(len(ts))
    vel = np.tile(v, (len(ts), 1)) if rng.random() < 0.6 else None
    if rng.random() < 0.4:
        ps = ts[-1] + np.array([0.0, 1.0, 2.0, 3.0])
        pen = en[-1] + np.outer(ps - ts[-1], v)
    else:
        ps, pen = np.empty(0), np.empty((0, 2))
    return now.UgvTrack(ts, en, sig, ps, pen, vel, float(rng.choice([0.0, 0.05, 0.8])))


def _scene(seed: int):
    """A random scene: (tracks, frames). UGVs seen or not, labels right, wrong or missing, labelled
    blobs, crowds beside UGVs, GNSS outliers, collinear layouts, time jumps, with and without a pose."""
    rng = np.random.default_rng(seed)
    n_ugv = int(rng.integers(3, 9))
    names = [f"ugv{i + 1}" for i in range(n_ugv)]
    layout = rng.random()
    if layout < 0.1:          # on a line: degenerate
        en0 = np.outer(np.linspace(-15, 15, n_ugv), rng.normal(0, 1, 2))
    else:
        en0 = rng.uniform(-18, 18, (n_ugv, 2))
    v = rng.normal(0, 1.0, (n_ugv, 2))
    alt = float(rng.uniform(30, 90))
    cam_pose = CameraPose(*rng.normal(0, 3, 2), alt, yaw_deg=float(rng.uniform(0, 360)),
                          roll_deg=float(rng.normal(0, 2)), pitch_deg=float(rng.normal(0, 2)))
    told = CameraPose(cam_pose.east_m + rng.normal(0, 1), cam_pose.north_m + rng.normal(0, 1), alt,
                      cam_pose.yaw_deg + rng.normal(0, 2), cam_pose.roll_deg, cam_pose.pitch_deg)
    lat, lon = FRAME.ground_to_wgs84(told.east_m, told.north_m)
    report = CameraPoseReport(float(lat), float(lon), alt, told.roll_deg, told.pitch_deg, told.yaw_deg % 360.0,
                              0.5, 1.0, 3.0, 1.0)
    prior = pose_prior(report, FRAME, CAM.width_px, CAM.height_px, CAM.focal_px)
    t_end = float(rng.uniform(1.0, 4.0))
    tracks = {u: _track(rng, en0[i], v[i], t_end) for i, u in enumerate(names)}
    gnss_bad = rng.random() < 0.2
    if gnss_bad:              # one UGV's fixes are 10 m off
        u = names[0]
        tracks[u] = now.UgvTrack(tracks[u].fix_stamp_s, tracks[u].fix_en_m + (10.0, -4.0), tracks[u].fix_sigma_m,
                                 tracks[u].plan_stamp_s, tracks[u].plan_en_m, tracks[u].fix_v_en_m_s,
                                 tracks[u].fix_latency_s)
    with_pose = rng.random() < 0.7
    frames, t = [], t_end - rng.uniform(0.5, 2.0)
    for k in range(24):
        t += float(rng.choice([0.033, 0.1, 0.4, 1.3, -0.2], p=[0.7, 0.1, 0.08, 0.04, 0.08]))
        en = en0 + v * t
        px = project(CAM, cam_pose, en)
        seen = [i for i in range(n_ugv) if np.isfinite(px[i]).all() and rng.random() < 0.85]
        labels = {}
        for i in seen:
            r = rng.random()
            if r < 0.8:
                labels[names[i]] = tuple(px[i] + rng.normal(0, 0.5, 2))
            elif r < 0.9:     # a patch of its color elsewhere
                labels[names[i]] = tuple(px[i] + rng.uniform(40, 200, 2) * rng.choice([-1, 1], 2))
        ugv_xy = [px[i] + rng.normal(0, 1.0, 2) for i in seen if rng.random() < 0.9]
        ugv_lab = [names[i] if rng.random() < 0.2 else "" for i in seen][:len(ugv_xy)]
        n_crowd = int(rng.choice([0, 1, 3, 12, 40]))
        crowd_xy = list(rng.uniform([0, 0], [1280, 720], (n_crowd, 2)))
        if seen and rng.random() < 0.3:      # a crowd beside a UGV
            crowd_xy.append(px[seen[0]] + rng.normal(0, 15, 2))
        xy = np.array(ugv_xy + crowd_xy, float).reshape(-1, 2)
        half = rng.uniform(3, 40, (len(xy), 2))
        blobs = Blobs(xy, np.column_stack([xy - half, xy + half]), rng.uniform(1, 500, len(xy)),
                      tuple(ugv_lab) + ("",) * len(crowd_xy))
        frames.append(now.FrameObservation(t, Landmarks.from_dict(labels), blobs, 0.5, 1.0, 1.5,
                                           prior if with_pose else None,
                                           CAM.focal_px / alt if rng.random() < 0.8 else None))
    return tracks, frames


def _same(a, b, where):
    assert (a.quality, a.landmarks_used, a.outlier_landmarks, a.blob_of_ugv, a.position_source, a.failure) == \
        (b.quality, b.landmarks_used, b.outlier_landmarks, b.blob_of_ugv, b.position_source, b.failure), where
    assert a.fit_age_s == pytest.approx(b.fit_age_s, abs=1e-12), where
    assert [(c.blob_index, c.quality, c.n_outliers, c.area_px) for c in a.crowds] == \
        [(c.blob_index, c.quality, c.n_outliers, c.area_px) for c in b.crowds], where
    for x, y in zip(a.crowds, b.crowds):
        _close([x.east_m, x.north_m, x.radius95_m], [y.east_m, y.north_m, y.radius95_m], where)
        _close(x.footprint_en_m, y.footprint_en_m, where)


def _same_state(a, b, where):
    assert (a.interval_start_s, a.blob_px_of_ugv, a.last_fit_stamp_s, a.pose_bias_n) == \
        (b.interval_start_s, b.blob_px_of_ugv, b.last_fit_stamp_s, b.pose_bias_n), where
    assert (a.last_fit is None) == (b.last_fit is None), where
    if a.last_fit is not None:
        np.testing.assert_allclose(a.last_fit.H_ground_from_px, b.last_fit.H_ground_from_px, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(a.last_fit_sigma_m, b.last_fit_sigma_m, rtol=0, atol=0)
    np.testing.assert_allclose(a.pose_bias_en_m, b.pose_bias_en_m, rtol=1e-12, atol=1e-12)
    assert a.pose_bias_var_m2 == pytest.approx(b.pose_bias_var_m2, rel=1e-12, abs=1e-12), where


CONFIGS = [
    {},                                                            # the defaults
    {"image_coordinates": "color"},                                # landmarks at their labels
    {"solver": "greedy", "gate_px": 40.0},                         # the paper's greedy pairing, a wide gate
    {"sigma_landmark_px": 2.0, "sigma_target_px": 3.0,             # pixel noise from the config; short holds
     "hold_max_s": 0.5, "prior_max_age_s": 0.3, "tracking_interval_s": 0.5},
    {"plan_hold_s": 3.0, "robust_threshold_m": 1.0, "fix_extrapolate_s": 0.1},   # long plans, a tight threshold
]


@pytest.mark.parametrize("seed", range(40))
def test_every_step_is_the_step_it_was(seed, monkeypatch):
    tracks, frames = _scene(seed)
    kw = CONFIGS[seed % len(CONFIGS)]
    # the landmarks' noise as declared, as it was then (learning it from the residuals came later and
    # changes radii only: test_localizer.py tests it); and the UGVs' claims at the fixed reach they had
    # then (under the pose the claim reaching as far as the pose is worth came later:
    # test_perception.py tests it), a label excusing a UGV's claim however fast it moves (a moving UGV's
    # label needing a blob of its own came later: test_localizer.py tests it), and a UGV's own blob however
    # small (one under min_vehicle_blob_m2 claiming the rest of the vehicle came later: test_perception.py),
    # and under a landmark fit at that reach whatever the fix's error (its 95 % radius added came later:
    # test_localizer.py tests it); and the last transform as a prior known as well everywhere as at its own
    # landmarks (known as well as they make it there came later: test_localizer.py tests it); and no crowd
    # fused with the camera's pose (that came later too: test_localizer.py tests it)
    prior_of = now.prior_of
    monkeypatch.setattr(now, "prior_of", lambda *a: (p := prior_of(*a)) and replace(p, fit_landmark_sigma_m=None))
    claim = now.claim_blobs
    monkeypatch.setattr(now, "claim_blobs", lambda to_px, obs, positions, pairing, cfg, pose_sigma_m=None:
                        claim(to_px, obs, {u: replace(p, sigma_m=0.0) for u, p in positions.items()}, pairing, cfg))
    cfg_now = now.LocalizerConfig(**kw, learn_landmark_noise=False, moving_m_s=float("inf"), min_vehicle_blob_m2=0.0,
                                  fuse_pose=False)
    cfg_before = before.LocalizerConfig(**kw)
    s_now, s_before = now.LocalizerState(), before.LocalizerState()
    for k, obs in enumerate(frames):
        s_before, want = before.localize_step(s_before, obs, tracks, cfg_before)
        s_now, got = now.localize_step(s_now, obs, tracks, cfg_now)
        _same(got, want, (seed, k))
        _same_state(s_now, s_before, (seed, k))


def test_the_scenes_take_every_path():
    # the scenes above are only worth their seeds if they reach every quality and position source
    qualities, sources = set(), set()
    for seed in range(40):
        tracks, frames = _scene(seed)
        cfg, st = now.LocalizerConfig(**CONFIGS[seed % len(CONFIGS)]), now.LocalizerState()
        for obs in frames:
            st, res = now.localize_step(st, obs, tracks, cfg)
            qualities.add(res.quality.value)
            sources.update(res.position_source.values())
    assert qualities >= {"exact", "least_squares", "robust", "suspect", "held", "pose", "failed"}, qualities
    assert sources == {"fix", "extrapolated", "plan"}, sources


@pytest.mark.parametrize("seed", range(60))
def test_the_fits_are_the_fits_they_were(seed):
    # homography fits of 4 to 9 points, some exact, some noisy, some with outliers or degenerate
    rng = np.random.default_rng(1000 + seed)
    n = int(rng.integers(4, 10))
    px = rng.uniform([0, 0], [1280, 720], (n, 2))
    H = np.array([[0.05, 0.01, -30.0], [-0.005, -0.06, 20.0], [1e-5, 2e-5, 1.0]]) * rng.uniform(0.5, 2, (3, 3))
    q = np.column_stack([px, np.ones(n)]) @ H.T
    en = q[:, :2] / q[:, 2:] + rng.normal(0, rng.choice([0.0, 0.05, 0.5]), (n, 2))
    if seed % 4 == 1:
        en[0] += 8.0                                        # one outlier
    if seed % 10 == 7:
        px[1] = px[0] + 0.1                                 # a duplicate
    if seed % 10 == 9:
        px[:, 1] = 2 * px[:, 0] + 3                         # collinear
    misfit = rng.uniform(0, 6, n) if seed % 3 else None
    for fit_of in ("fit_homography", "fit_homography_robust"):
        kw = {"threshold_m": 1.0, "prior_misfit": misfit} if fit_of.endswith("robust") else {}
        a = getattr(hom_now, fit_of)(px, en, **kw)
        b = getattr(hom_before, fit_of)(px, en, **kw)
        assert bool(a) == bool(b)
        if not b:
            assert (a.reason.value, a.detail) == (b.reason.value, b.detail)
            continue
        assert a.quality == b.quality and (a.inliers == b.inliers).all()
        np.testing.assert_allclose(a.H_ground_from_px, b.H_ground_from_px, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(a.H_px_from_ground, b.H_px_from_ground, rtol=1e-12, atol=1e-12)
        _close(a.residual_m, b.residual_m, seed)
        _close(a.rms_residual_m, b.rms_residual_m, seed)
        targets = rng.uniform([0, 0], [1280, 720], (7, 2))
        sig_m = rng.uniform(0, 1, n)
        ea, ca = a.map_points_with_cov(targets, 1.5, 1.0, sig_m)
        eb, cb = b.map_points_with_cov(targets, 1.5, 1.0, sig_m)
        _close(ea, eb, seed)
        np.testing.assert_allclose(ca, cb, rtol=1e-9, atol=1e-12)
        _close(hom_now.radius95_m(ca), hom_before.radius95_m(cb), seed)
