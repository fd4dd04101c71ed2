# FROZEN: uvteam/homography.py as it was at commit 4d30179 (before the localizer was made faster), the reference
# that uvteam_ground.bench_localize measures the product against and checks it equals. Do not edit.
"""Plane-to-plane perspective transform between UAV image pixels and the local ground plane.

The paper's model: ground = H(image) with 8 unknowns (h33 = 1), one pair of linear equations per
landmark correspondence; exact for n = 4, linear least squares for n > 4. Here the system is solved
in Hartley-normalised coordinates (centroid at 0, mean distance sqrt 2) with an SVD-based solver
(numpy.linalg.lstsq), never an explicit inverse of A^T A.

Degenerate input never produces a matrix: :func:`fit_homography` returns a :class:`FitFailure` that
names the reason (too few points, non-finite values, duplicates, collinear, ill-conditioned).

Uncertainty: :meth:`Homography.map_points_with_cov` propagates landmark pixel noise, landmark ground
(GNSS) noise and target pixel noise to a 2x2 ground covariance per point, to first order through
the least-squares solution (Gauss-Newton: dh = -A^+ (dr/dz) dz), and :func:`radius95_m` turns a
covariance into the radius of the circle around the estimate that holds 95 % of the probability.

Frames: image points are ``xy_px`` (N, 2), origin top-left; ground points ``en_m`` (N, 2), east and
north metres in a :class:`uvteam.geo.LocalFrame`.
"""

from __future__ import annotations

import enum
import itertools
from dataclasses import dataclass, field
from math import erf, sqrt

import numpy as np

from uvteam.vocab import FitQuality

__all__ = [
    "FitQuality", "FailureReason", "FitFailure", "Homography", "fit_homography",
    "fit_homography_robust", "radius95_m",
]


class FailureReason(str, enum.Enum):
    TOO_FEW = "too_few"
    NON_FINITE = "non_finite"
    DUPLICATE = "duplicate"
    COLLINEAR = "collinear"
    ILL_CONDITIONED = "ill_conditioned"
    SHAPE = "shape"


@dataclass(frozen=True, slots=True)
class FitFailure:
    reason: FailureReason
    detail: str

    def __bool__(self) -> bool:  # a failure is falsy so that `if fit:` reads naturally
        return False


def _normaliser(pts: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Hartley normalisation: returns (centroid, scale, T) with T @ [x, y, 1] normalised."""
    c = pts.mean(axis=0)
    d = np.sqrt(((pts - c) ** 2).sum(axis=1)).mean()
    s = sqrt(2.0) / d if d > 0 else 1.0
    T = np.array([[s, 0.0, -s * c[0]], [0.0, s, -s * c[1]], [0.0, 0.0, 1.0]])
    return c, s, T


def _design(p: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The paper's 2n x 8 system A h = b for ground = H(image), h33 = 1."""
    n = len(p)
    x, y, X, Y = p[:, 0], p[:, 1], g[:, 0], g[:, 1]
    A = np.zeros((2 * n, 8))
    A[0::2, 0], A[0::2, 1], A[0::2, 2] = x, y, 1.0
    A[0::2, 6], A[0::2, 7] = -X * x, -X * y
    A[1::2, 3], A[1::2, 4], A[1::2, 5] = x, y, 1.0
    A[1::2, 6], A[1::2, 7] = -Y * x, -Y * y
    b = np.empty(2 * n)
    b[0::2], b[1::2] = X, Y
    return A, b


PRIOR_SIGMAS = 4.0      # a landmark this many sigmas from its prior makes the fit look for one that lies
_COLLINEAR_TOL = 1e-3   # smallest/largest singular value of the centred, normalised points
_COND_MAX = 1e7         # condition number of the normalised design matrix


def _check(xy_px: np.ndarray, en_m: np.ndarray, min_sep_px: float, min_sep_m: float) -> FitFailure | None:
    if xy_px.ndim != 2 or xy_px.shape[1] != 2 or en_m.shape != xy_px.shape:
        return FitFailure(FailureReason.SHAPE, f"need (n, 2) and (n, 2), got {xy_px.shape} and {en_m.shape}")
    n = len(xy_px)
    if n < 4:
        return FitFailure(FailureReason.TOO_FEW, f"need at least 4 landmarks, got {n}")
    if not (np.isfinite(xy_px).all() and np.isfinite(en_m).all()):
        return FitFailure(FailureReason.NON_FINITE, "a landmark coordinate is NaN or infinite")
    iu = np.triu_indices(n, 1)
    for pts, tol, what in ((xy_px, min_sep_px, "image"), (en_m, min_sep_m, "ground")):
        diff = pts[iu[0]] - pts[iu[1]]
        d2 = diff[:, 0] * diff[:, 0] + diff[:, 1] * diff[:, 1]
        k = int(d2.argmin())
        if d2[k] <= tol * tol:
            return FitFailure(FailureReason.DUPLICATE,
                              f"landmarks {iu[0][k]} and {iu[1][k]} coincide in the {what} ({sqrt(d2[k]):.3g} apart)")
    for pts, what in ((xy_px, "image"), (en_m, "ground")):
        c = pts - pts.mean(axis=0)
        S = c.T @ c
        sxx, syy, sxy = S[0, 0], S[1, 1], S[0, 1]
        tr, disc = 0.5 * (sxx + syy), sqrt(max((0.5 * (sxx - syy)) ** 2 + sxy * sxy, 0.0))
        if tr - disc <= (_COLLINEAR_TOL ** 2) * (tr + disc):  # singular values squared
            return FitFailure(FailureReason.COLLINEAR, f"landmarks are collinear in the {what}")
        if n == 4:  # with four points, any three on a line make the system singular
            for tri in itertools.combinations(range(4), 3):
                q = pts[list(tri)]
                area2 = abs((q[1, 0] - q[0, 0]) * (q[2, 1] - q[0, 1]) - (q[1, 1] - q[0, 1]) * (q[2, 0] - q[0, 0]))
                scale2 = max(((q - q.mean(0)) ** 2).sum(1).max(), 1e-300)
                if area2 <= 2 * _COLLINEAR_TOL * scale2:
                    return FitFailure(FailureReason.COLLINEAR, f"landmarks {tri} are collinear in the {what}")
    return None


@dataclass(frozen=True, slots=True)
class Homography:
    """ground = H_ground_from_px (image). Carries what the fit needs for uncertainty propagation."""

    H_ground_from_px: np.ndarray           # (3, 3), H[2, 2] = 1
    H_px_from_ground: np.ndarray           # its inverse scaled by |H22|: w > 0 in front of the camera
    quality: FitQuality
    inliers: np.ndarray                    # (n,) bool over the landmarks given to the fit
    rms_residual_m: float                  # ground-plane RMS residual over inliers (0 for exact fits)
    residual_m: np.ndarray                 # (n,) ground distance of every landmark from its mapped pixel
    # Normalised-space quantities for covariance propagation (first order).
    _h_n: np.ndarray = field(repr=False)          # (8,)
    _A_pinv: np.ndarray = field(repr=False)       # (8, 2m)
    _dr_dz: np.ndarray = field(repr=False)        # (2m, 4m) block diagonal
    _Tp: np.ndarray = field(repr=False)
    _sp: float = field(repr=False)
    _sg: float = field(repr=False)
    _Tg_inv: np.ndarray = field(repr=False)

    @property
    def outliers(self) -> np.ndarray:
        return np.flatnonzero(~self.inliers)

    def px_to_ground(self, xy_px) -> np.ndarray:
        """(N, 2) pixels -> (N, 2) east/north metres. Points at or beyond the horizon give NaN."""
        return _apply(self.H_ground_from_px, xy_px)

    def ground_to_px(self, en_m) -> np.ndarray:
        return _apply(self.H_px_from_ground, en_m)

    def polygon_to_ground(self, poly_px) -> np.ndarray:
        """A polygon's vertices (K, 2) px -> (K, 2) m; straight edges stay straight under H."""
        return self.px_to_ground(poly_px)

    def with_quality(self, quality: FitQuality) -> "Homography":
        return Homography(self.H_ground_from_px, self.H_px_from_ground, quality, self.inliers, self.rms_residual_m,
                          self.residual_m, self._h_n,
                          self._A_pinv, self._dr_dz, self._Tp, self._sp, self._sg, self._Tg_inv)

    def map_points_with_cov(self, xy_px, sigma_target_px: float, sigma_landmark_px,
                            sigma_landmark_m) -> tuple[np.ndarray, np.ndarray]:
        """Map target pixels to ground and propagate noise to a (N, 2, 2) covariance in m^2.

        sigma_landmark_px / sigma_landmark_m: scalar or (n,) 1-sigma per axis for every landmark given
        to the fit (image noise and GNSS noise); outliers' entries are ignored; sigma_target_px: 1-sigma per axis of each target's pixel centre.
        """
        xy = np.atleast_2d(np.asarray(xy_px, float))
        n_all = len(self.inliers)
        sp = np.broadcast_to(np.asarray(sigma_landmark_px, float), (n_all,))[self.inliers] * self._sp
        sg = np.broadcast_to(np.asarray(sigma_landmark_m, float), (n_all,))[self.inliers] * self._sg
        m = len(sp)
        var_z = np.empty(4 * m)
        var_z[0::4], var_z[1::4], var_z[2::4], var_z[3::4] = sp ** 2, sp ** 2, sg ** 2, sg ** 2
        J_h = -self._A_pinv @ self._dr_dz                  # (8, 4m)
        cov_h = (J_h * var_z) @ J_h.T                      # (8, 8) normalised
        h = self._h_n
        # targets in normalised image coordinates
        u = xy[:, 0] * self._sp + self._Tp[0, 2]
        v = xy[:, 1] * self._sp + self._Tp[1, 2]
        w = h[6] * u + h[7] * v + 1.0
        X = (h[0] * u + h[1] * v + h[2]) / w
        Y = (h[3] * u + h[4] * v + h[5]) / w
        n = len(xy)
        Jf = np.zeros((n, 2, 8))
        Jf[:, 0, 0], Jf[:, 0, 1], Jf[:, 0, 2] = u, v, 1.0
        Jf[:, 0, 6], Jf[:, 0, 7] = -X * u, -X * v
        Jf[:, 1, 3], Jf[:, 1, 4], Jf[:, 1, 5] = u, v, 1.0
        Jf[:, 1, 6], Jf[:, 1, 7] = -Y * u, -Y * v
        Jf /= w[:, None, None]
        Jp = np.empty((n, 2, 2))
        Jp[:, 0, 0], Jp[:, 0, 1] = (h[0] - X * h[6]) / w, (h[1] - X * h[7]) / w
        Jp[:, 1, 0], Jp[:, 1, 1] = (h[3] - Y * h[6]) / w, (h[4] - Y * h[7]) / w
        st = sigma_target_px * self._sp
        cov_n = Jf @ cov_h @ Jf.transpose(0, 2, 1) + (st ** 2) * (Jp @ Jp.transpose(0, 2, 1))
        cov_m = cov_n / (self._sg ** 2)
        en = np.stack([X, Y], axis=1) / self._sg + self._Tg_inv[:2, 2]
        bad = ~(w > 1e-12)
        en[bad] = np.nan
        cov_m[bad] = np.nan
        return en, cov_m


def _apply(H: np.ndarray, pts) -> np.ndarray:
    p = np.asarray(pts, float).reshape(-1, 2)
    q = p @ H[:, :2].T + H[:, 2]                  # (N, 3) homogeneous
    w = q[:, 2:]
    ok = w > 1e-12                                # in front of the camera (or of the ground plane)
    return np.divide(q[:, :2], w, out=np.full((len(p), 2), np.nan), where=ok)


def fit_homography(xy_px, en_m, *, min_sep_px: float = 0.5, min_sep_m: float = 0.05,
                   inliers: np.ndarray | None = None, quality: FitQuality | None = None) -> Homography | FitFailure:
    """Fit ground = H(image) from n >= 4 correspondences: exact for 4, least squares for more."""
    p_all = np.asarray(xy_px, float)
    g_all = np.asarray(en_m, float)
    mask = np.ones(len(p_all), bool) if inliers is None else np.asarray(inliers, bool)
    p, g = p_all[mask] if p_all.ndim == 2 else p_all, g_all[mask] if g_all.ndim == 2 else g_all
    bad = _check(p, g, min_sep_px, min_sep_m)
    if bad is not None:
        return bad
    _, sp, Tp = _normaliser(p)
    _, sg, Tg = _normaliser(g)
    pn = p * sp + Tp[:2, 2]
    gn = g * sg + Tg[:2, 2]
    A, b = _design(pn, gn)
    # One thin SVD gives the condition number, the solution and the pseudo-inverse.
    U, sv, Vt = np.linalg.svd(A, full_matrices=False)
    if sv[-1] <= sv[0] / _COND_MAX:
        return FitFailure(FailureReason.ILL_CONDITIONED, f"condition number {sv[0] / max(sv[-1], 1e-300):.3g}")
    A_pinv = (Vt.T / sv) @ U.T
    h = A_pinv @ b
    Hn = np.append(h, 1.0).reshape(3, 3)
    Tg_inv = np.array([[1 / sg, 0, -Tg[0, 2] / sg], [0, 1 / sg, -Tg[1, 2] / sg], [0, 0, 1.0]])
    H = Tg_inv @ Hn @ Tp
    if not np.isfinite(H).all() or abs(H[2, 2]) < 1e-300:
        return FitFailure(FailureReason.ILL_CONDITIONED, "the solved transform is not finite")
    H = H / H[2, 2]
    # residual Jacobian wrt z = (x, y, X, Y) per landmark, block diagonal (Gauss-Newton)
    m = len(pn)
    x, y, X, Y = pn[:, 0], pn[:, 1], gn[:, 0], gn[:, 1]
    w = h[6] * x + h[7] * y + 1.0
    dr = np.zeros((2 * m, 4 * m))
    r0, r1 = np.arange(m) * 2, np.arange(m) * 2 + 1
    c = np.arange(m) * 4
    dr[r0, c], dr[r0, c + 1], dr[r0, c + 2] = h[0] - X * h[6], h[1] - X * h[7], -w
    dr[r1, c], dr[r1, c + 1], dr[r1, c + 3] = h[3] - Y * h[6], h[4] - Y * h[7], -w
    resid = _apply(H, p_all) - g_all
    res_m = np.sqrt(resid[:, 0] ** 2 + resid[:, 1] ** 2)
    rms = float(np.sqrt((res_m[mask] ** 2).mean()))
    q = quality or (FitQuality.EXACT if m == 4 else FitQuality.LEAST_SQUARES)
    # inverse scaled by |H22| only: inv(H) [g; 1] = [p; 1] / w(p), so w > 0 marks points in front
    Hinv = np.linalg.inv(H)
    Hinv /= abs(Hinv[2, 2])
    return Homography(H, Hinv, q, mask.copy(), rms if m > 4 else 0.0, res_m, h, A_pinv, dr, Tp, sp, sg, Tg_inv)


def fit_homography_robust(xy_px, en_m, *, threshold_m: float, min_sep_px: float = 0.5, min_sep_m: float = 0.05,
                          prior_misfit: np.ndarray | None = None) -> Homography | FitFailure:
    """Least squares on the largest consensus set; names outlier landmarks.

    With the few landmarks a UGV team has (n <= 10) every 4-subset is tried (at most 210 exact fits),
    which is deterministic and cannot miss the best hypothesis as random sampling can; beyond that,
    OpenCV's USAC MAGSAC++ proposes the inliers. A landmark is an inlier when the hypothesis maps its
    pixel to within ``threshold_m`` of its ground position. n = 4 has no redundancy: plain fit.

    Consensus alone cannot tell which landmark lies when several sets are as large: with 5 landmarks
    of which one is wrong, every 4-subset fits exactly, so "drop the wrong one" and "drop a good one"
    both leave 4 inliers and 1 outlier. ``prior_misfit`` (n,) breaks such ties: how far each landmark
    disagrees with what was known before this frame (its distance from where a prior transform maps its
    pixel, in its own sigmas: :func:`uvteam.localizer.fit_transform`); of the largest consensus sets,
    the one whose members disagree least with the prior wins. Without a prior, the smallest summed
    residual does (round-off may then decide).
    """
    p = np.asarray(xy_px, float)
    g = np.asarray(en_m, float)
    n = len(p)
    if n <= 4:
        return fit_homography(p, g, min_sep_px=min_sep_px, min_sep_m=min_sep_m)
    full = fit_homography(p, g, min_sep_px=min_sep_px, min_sep_m=min_sep_m)
    if not full:
        return full
    misfit = None if prior_misfit is None else np.asarray(prior_misfit, float).reshape(n)
    # common case first: every landmark agrees with the fit of all of them (and with the prior: five
    # landmarks leave a homography two spare degrees of freedom, enough to bend round one wrong point)
    if full.residual_m.max() <= threshold_m and (misfit is None or misfit.max() <= PRIOR_SIGMAS):
        return full
    if misfit is not None:   # the landmarks the prior agrees with, if they are enough and agree among themselves
        agree = misfit <= PRIOR_SIGMAS
        if 4 <= agree.sum() < n:
            hyp = fit_homography(p, g, inliers=agree, min_sep_px=min_sep_px, min_sep_m=min_sep_m)
            if hyp and hyp.residual_m[agree].max() <= threshold_m:
                inl = hyp.residual_m <= threshold_m     # those the prior doubted but this fit does not stay in
                fit = fit_homography(p, g, inliers=inl, min_sep_px=min_sep_px, min_sep_m=min_sep_m)
                if fit:
                    return fit.with_quality(FitQuality.ROBUST) if (~inl).any() else fit
    best: np.ndarray | None = None
    best_key = (np.inf, np.inf)
    if n <= 10:
        for quad in itertools.combinations(range(n), 4):
            sel = np.zeros(n, bool)
            sel[list(quad)] = True
            hyp = fit_homography(p, g, inliers=sel, min_sep_px=min_sep_px, min_sep_m=min_sep_m)
            if not hyp:
                continue
            err = hyp.residual_m
            inl = err <= threshold_m
            score = float(np.where(inl, err, threshold_m).sum())
            # fewest outliers first; then the set the prior agrees with, else the smallest residuals
            key = (-int(inl.sum()), float(np.square(misfit[inl]).sum()) if misfit is not None else score)
            if best is None or key < best_key:
                best, best_key = inl, key
    else:
        import cv2  # noqa: PLC0415 - only needed for large landmark sets

        _, cv_mask = cv2.findHomography(p.astype(np.float64), g.astype(np.float64), cv2.USAC_MAGSAC,
                                        threshold_m)
        if cv_mask is not None:
            best = cv_mask.ravel().astype(bool)
    if best is None or best.sum() < 4:
        return full
    fit = fit_homography(p, g, inliers=best, min_sep_px=min_sep_px, min_sep_m=min_sep_m)
    if fit and (~best).any():
        return fit.with_quality(FitQuality.ROBUST)
    return fit


# --- 95 % radius of a 2-D Gaussian ------------------------------------------------------------
def _p_inside(r: float, k: float) -> float:
    """P(a^2 + (k b)^2 <= r^2) for a, b ~ N(0, 1), 0 <= k <= 1."""
    if k < 1e-9:
        return erf(r / sqrt(2.0))
    bmax = r / k
    b = np.linspace(-bmax, bmax, 801)
    a = np.sqrt(np.maximum(r * r - (k * b) ** 2, 0.0) / 2.0)
    from scipy.special import erf as verf  # noqa: PLC0415

    f = np.exp(-b * b / 2) / sqrt(2 * np.pi) * verf(a)
    return float(np.trapezoid(f, b))


def _r95(k: float) -> float:
    lo, hi = 1.5, 2.6
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _p_inside(mid, k) < 0.95 else (lo, mid)
    return 0.5 * (lo + hi)


_K_GRID = np.linspace(0.0, 1.0, 41)
_R95_GRID: np.ndarray | None = None


def radius95_m(cov_m2) -> np.ndarray:
    """Radius of the circle centred on the estimate that holds 95 % of a 2-D Gaussian with the given
    (..., 2, 2) covariance: sqrt(lambda_max) * g(sqrt(lambda_min / lambda_max)); g from 1.960 (a line)
    to 2.448 (a circle), tabulated once by quadrature."""
    global _R95_GRID
    if _R95_GRID is None:
        _R95_GRID = np.array([_r95(k) for k in _K_GRID])
    cov = np.asarray(cov_m2, float)
    a, b, d = cov[..., 0, 0], 0.5 * (cov[..., 0, 1] + cov[..., 1, 0]), cov[..., 1, 1]
    tr, disc = 0.5 * (a + d), np.sqrt(np.maximum((0.5 * (a - d)) ** 2 + b * b, 0.0))
    lmax, lmin = tr + disc, np.maximum(tr - disc, 0.0)
    k = np.sqrt(np.divide(lmin, lmax, out=np.ones_like(lmax), where=lmax > 0))
    return np.sqrt(lmax) * np.interp(k, _K_GRID, _R95_GRID)
