import itertools

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uvteam.camera import CameraPose, PinholeCamera, H_px_from_ground, project
from uvteam.homography import (FailureReason, FitQuality, fit_homography, fit_homography_robust,
                               radius95_m)

H_TRUE = np.array([[0.05, 0.01, -30.0], [-0.005, -0.06, 20.0], [1e-5, 2e-5, 1.0]])


def apply(H, p):
    q = np.column_stack([p, np.ones(len(p))]) @ H.T
    return q[:, :2] / q[:, 2:]


def rel_err(A, B):
    return np.abs(A / A[2, 2] - B / B[2, 2]).max() / np.abs(B).max()


@pytest.mark.parametrize("n", [4, 5, 6, 10, 30])
def test_exact_recovery(n):
    rng = np.random.default_rng(n)
    px = rng.uniform([0, 0], [1280, 720], (n, 2))
    fit = fit_homography(px, apply(H_TRUE, px))
    assert fit, fit
    assert rel_err(fit.H_ground_from_px, H_TRUE) < 1e-9
    assert fit.quality == (FitQuality.EXACT if n == 4 else FitQuality.LEAST_SQUARES)


def test_agrees_with_opencv():
    rng = np.random.default_rng(7)
    px = rng.uniform([0, 0], [1280, 720], (4, 2))
    g = apply(H_TRUE, px)
    ours = fit_homography(px, g).H_ground_from_px
    assert rel_err(ours, cv2.getPerspectiveTransform(px.astype(np.float32), g.astype(np.float32))) < 1e-5
    px6 = rng.uniform([0, 0], [1280, 720], (6, 2))
    g6 = apply(H_TRUE, px6) + rng.normal(0, 0.05, (6, 2))
    cvH, _ = cv2.findHomography(px6, g6, 0)
    # both are least squares (ours algebraic in normalised coordinates, OpenCV refines geometrically):
    # they agree on the ground to well under the noise
    grid = np.array(list(itertools.product(np.linspace(0, 1280, 5), np.linspace(0, 720, 5))))
    assert np.abs(fit_homography(px6, g6).px_to_ground(grid) - apply(cvH, grid)).max() < 0.05


@settings(max_examples=50, deadline=None)
@given(st.integers(4, 8), st.integers(0, 10_000), st.randoms(use_true_random=False))
def test_order_invariance_and_inverse(n, seed, rnd):
    rng = np.random.default_rng(seed)
    px = rng.uniform([0, 0], [1280, 720], (n, 2))
    g = apply(H_TRUE, px) + rng.normal(0, 0.1, (n, 2))
    a = fit_homography(px, g)
    perm = list(range(n))
    rnd.shuffle(perm)
    b = fit_homography(px[perm], g[perm])
    if not a:  # random points may be near-degenerate: then both must say so
        assert not b
        return
    assert rel_err(a.H_ground_from_px, b.H_ground_from_px) < 1e-8
    pts = rng.uniform([0, 0], [1280, 720], (10, 2))
    g_pts = a.px_to_ground(pts)
    ok = np.isfinite(g_pts).all(1)  # a noisy fit of near-degenerate points may put pixels past its horizon
    np.testing.assert_allclose(a.ground_to_px(g_pts[ok]), pts[ok], atol=1e-5)


@pytest.mark.parametrize(
    "px, reason",
    [
        ([[0, 0], [100, 0], [0, 100]], FailureReason.TOO_FEW),                        # three points
        (np.empty((0, 2)), FailureReason.TOO_FEW),                                    # nothing at all
        (np.zeros((4, 3)), FailureReason.SHAPE),                                      # not (n, 2)
        ([[0, 0], [100, 0], [0, 100], [100, 100.0], [np.nan, 5]], FailureReason.NON_FINITE),  # a NaN
        ([[0, 0], [100, 0], [0, 100], [0, 100.2]], FailureReason.DUPLICATE),          # two coincide
        ([[0, 0], [100, 100], [200, 200], [300, 300.0]], FailureReason.COLLINEAR),    # all on a line
        ([[0, 0], [100, 0], [200, 0], [50, 300.0]], FailureReason.COLLINEAR),         # 3 of 4 on a line
        ([[0, 0], [100, 0], [200, 0.01], [300, 0], [400, 0.02]], FailureReason.COLLINEAR),  # nearly a line
    ],
)
def test_degenerate_inputs_give_typed_failure(px, reason):
    px = np.asarray(px, float)
    g = apply(H_TRUE, px[:, :2]) if px.ndim == 2 and len(px) else np.empty((0, 2))
    if px.shape[-1] == 3:
        g = np.zeros((4, 3))
    fit = fit_homography(px, g)
    assert not fit
    assert fit.reason == reason


def test_robust_names_outlier():
    rng = np.random.default_rng(3)
    px = rng.uniform([100, 100], [1180, 620], (6, 2))
    g = apply(H_TRUE, px)
    g[4] += [8.0, -5.0]  # one UGV reports a wrong fix
    fit = fit_homography_robust(px, g, threshold_m=2.0)
    assert fit.quality == FitQuality.ROBUST
    assert list(fit.outliers) == [4]
    assert rel_err(fit.H_ground_from_px, H_TRUE) < 1e-9


def test_robust_without_outliers_is_least_squares():
    rng = np.random.default_rng(4)
    px = rng.uniform([100, 100], [1180, 620], (6, 2))
    fit = fit_homography_robust(px, apply(H_TRUE, px), threshold_m=2.0)
    assert fit.quality == FitQuality.LEAST_SQUARES and fit.inliers.all()


def test_camera_homography_matches_projection():
    cam = PinholeCamera(1280, 720, 78.0)
    pose = CameraPose(3.0, -2.0, 50.0, yaw_deg=20.0, roll_deg=1.0, pitch_deg=-0.5)
    g = np.random.default_rng(1).uniform(-20, 20, (8, 2))
    px = project(cam, pose, g)
    np.testing.assert_allclose(apply(H_px_from_ground(cam, pose), g), px, atol=1e-9)
    fit = fit_homography(px[:4], g[:4])
    np.testing.assert_allclose(fit.px_to_ground(px), g, atol=1e-7)


def test_radius95_limits():
    # isotropic: sqrt(chi2_2(0.95)) = 2.4477 sigma; a line: 1.96 sigma
    assert radius95_m(np.eye(2)) == pytest.approx(2.4477, abs=2e-3)
    assert radius95_m(np.diag([4.0, 0.0])) == pytest.approx(2 * 1.96, abs=5e-3)
    rng = np.random.default_rng(0)
    cov = np.array([[4.0, 1.0], [1.0, 1.0]])
    r = radius95_m(cov)
    z = rng.multivariate_normal([0, 0], cov, 200_000)
    assert np.mean(np.hypot(z[:, 0], z[:, 1]) <= r) == pytest.approx(0.95, abs=0.003)


def test_the_fixes_part_of_a_target_s_covariance_is_theirs_alone():
    # with fixes_alone the last covariance is the one the landmarks' ground noise makes with no pixel noise
    # anywhere; the pixel and fix parts add up to the landmarks' whole part (first order: linear in the variances)
    rng = np.random.default_rng(3)
    px = rng.uniform([0, 0], [1280, 720], (6, 2))
    fit = fit_homography(px, apply(H_TRUE, px) + rng.normal(0, 0.3, (6, 2)))
    targets = rng.uniform([0, 0], [1280, 720], (5, 2))
    sig_m = np.array([1.0, 0.5, 2.0, 1.0, 0.02, 1.0])
    en, (whole, fixes) = fit.map_points_with_covs(targets, (0.0,), 0.8, sig_m, fixes_alone=True)
    _, alone = fit.map_points_with_cov(targets, 0.0, 0.0, sig_m)
    _, pixels = fit.map_points_with_cov(targets, 0.0, 0.8, 0.0)
    assert np.allclose(fixes, alone, rtol=1e-9, atol=1e-15)
    assert np.allclose(whole, pixels + fixes, rtol=1e-9, atol=1e-15)
    assert (fixes[:, 0, 0] > 0).all() and np.allclose(en, fit.px_to_ground(targets))
