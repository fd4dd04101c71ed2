"""Plane-to-plane perspective transform between UAV image pixels and the local ground plane.

The paper's model: ground = H(image) with 8 unknowns (h33 = 1), one pair of linear equations per
landmark correspondence; exact for n = 4, linear least squares for n > 4. Here the system is solved
in Hartley-normalised coordinates (centroid at 0, mean distance sqrt 2) with an SVD-based solver
(numpy.linalg.svd), never an explicit inverse of A^T A.

Speed: a fit is a handful of landmarks, where each numpy call costs more than the arithmetic it does
(about 1-2 us against 0.05 us for a float operation), so the per-landmark work (checks, normalisation,
design, residuals) is done in plain floats, and arrays are kept for what is linear algebra or scales
with the number of targets (the SVD, covariance propagation, mapping blobs).

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
from math import erf, inf, isfinite, nan, sqrt
from typing import NamedTuple

import numpy as np

from .vocab import FitQuality

__all__ = [
    "FitQuality", "FailureReason", "FitFailure", "Homography", "fit_homography",
    "fit_homography_robust", "radius95_m", "map_few",
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


def _hartley(pts: list[list[float]]) -> tuple[float, float, float]:
    """Hartley normalisation of plain points: (scale, x offset, y offset) such that x * scale + offset
    puts the centroid at 0 and the mean distance from it at sqrt 2 (as :func:`_normaliser`)."""
    n = len(pts)
    sx = sy = 0.0
    for x, y in pts:
        sx += x
        sy += y
    cx, cy = sx / n, sy / n
    d = 0.0
    for x, y in pts:
        d += sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy))
    d /= n
    s = sqrt(2.0) / d if d > 0 else 1.0
    return s, -s * cx, -s * cy


def map_few(H: np.ndarray, pts) -> list[tuple[float, float]]:
    """A few (x, y) points through the 3 x 3 homography ``H`` in plain floats (NaN beyond the horizon,
    w <= 1e-12, as :meth:`Homography.px_to_ground`): below about ten points this costs less than arrays."""
    (a, b, c), (d, e, f), (g, h, k) = H.tolist()
    out = []
    for x, y in pts:
        w = g * x + h * y + k
        out.append(((a * x + b * y + c) / w, (d * x + e * y + f) / w) if w > 1e-12 else (nan, nan))
    return out


PRIOR_SIGMAS = 4.0      # a landmark this many sigmas from its prior makes the fit look for one that lies
_COLLINEAR_TOL = 1e-3   # smallest/largest singular value of the centred, normalised points
_COND_MAX = 1e7         # condition number of the normalised design matrix


def _landmarks(p_all: np.ndarray, g_all: np.ndarray, mask: np.ndarray | None) -> tuple[list, list] | FitFailure:
    """The landmarks ``mask`` selects (all when None) as plain [x, y] lists, image and ground, or why
    they cannot be fitted (shape, count, a non-finite value)."""
    p, g = (p_all, g_all) if mask is None else \
        (p_all[mask] if p_all.ndim == 2 else p_all, g_all[mask] if g_all.ndim == 2 else g_all)
    if p.ndim != 2 or p.shape[1] != 2 or g.shape != p.shape:
        return FitFailure(FailureReason.SHAPE, f"need (n, 2) and (n, 2), got {p.shape} and {g.shape}")
    if len(p) < 4:
        return FitFailure(FailureReason.TOO_FEW, f"need at least 4 landmarks, got {len(p)}")
    img, gnd = p.tolist(), g.tolist()
    if not all(isfinite(v) for pts in (img, gnd) for pt in pts for v in pt):
        return FitFailure(FailureReason.NON_FINITE, "a landmark coordinate is NaN or infinite")
    return img, gnd


def _closest_pair(pts: list) -> tuple[float, int, int]:
    """(squared distance, i, j) of the closest two points, the first such pair in (i, j) order."""
    best, bi, bj = inf, 0, 0
    for i in range(len(pts)):
        xi, yi = pts[i]
        for j in range(i + 1, len(pts)):
            xj, yj = pts[j]
            d2 = (xi - xj) * (xi - xj) + (yi - yj) * (yi - yj)
            if d2 < best:
                best, bi, bj = d2, i, j
    return best, bi, bj


def _check_geometry(img: list, gnd: list, min_sep_px: float, min_sep_m: float) -> FitFailure | None:
    """Duplicate landmarks, then collinear ones, in the image then on the ground (plain [x, y] lists:
    a handful of points costs less in floats than in arrays)."""
    for pts, tol, what in ((img, min_sep_px, "image"), (gnd, min_sep_m, "ground")):
        d2, i, j = _closest_pair(pts)
        if d2 <= tol * tol:
            return FitFailure(FailureReason.DUPLICATE, f"landmarks {i} and {j} coincide in the {what} ({sqrt(d2):.3g} apart)")
    n = len(img)
    for pts, what in ((img, "image"), (gnd, "ground")):
        mx = my = 0.0
        for x, y in pts:
            mx += x
            my += y
        mx, my = mx / n, my / n
        sxx = syy = sxy = 0.0
        for x, y in pts:
            sxx += (x - mx) * (x - mx)
            syy += (y - my) * (y - my)
            sxy += (x - mx) * (y - my)
        half = 0.5 * (sxx - syy)          # (products, not ** 2: plain floats raise on overflow)
        tr, disc = 0.5 * (sxx + syy), sqrt(max(half * half + sxy * sxy, 0.0))
        if tr - disc <= (_COLLINEAR_TOL ** 2) * (tr + disc):  # singular values squared
            return FitFailure(FailureReason.COLLINEAR, f"landmarks are collinear in the {what}")
        if n == 4:  # with four points, any three on a line make the system singular
            for tri in itertools.combinations(range(4), 3):
                (x0, y0), (x1, y1), (x2, y2) = (pts[i] for i in tri)
                area2 = abs((x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0))
                mx, my = (x0 + x1 + x2) / 3, (y0 + y1 + y2) / 3
                scale2 = max(max((x - mx) * (x - mx) + (y - my) * (y - my) for x, y in ((x0, y0), (x1, y1), (x2, y2))),
                             1e-300)
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
        en, (cov_m,) = self.map_points_with_covs(xy_px, (sigma_target_px,), sigma_landmark_px, sigma_landmark_m)
        return en, cov_m

    def map_points_with_covs(self, xy_px, sigmas_target_px, sigma_landmark_px, sigma_landmark_m,
                             fixes_alone: bool = False) -> tuple[np.ndarray, list[np.ndarray]]:
        """As :meth:`map_points_with_cov`, with one (N, 2, 2) covariance per target sigma in
        ``sigmas_target_px``, the landmarks' part propagated once; with ``fixes_alone`` one more, last: the
        part the landmarks' ground noise (``sigma_landmark_m``) makes alone.

        In normalised coordinates a target's pixel is a = (u, v, 1), q = Hn a, its ground point
        (X, Y) = (q1, q2) / w with w = q3, and to first order it moves by G (dHn a + Hn[:, :2] da) / w with
        G = [[1, 0, -X], [0, 1, -Y]]. Its covariance is therefore G Q G^T / w^2 with the 3 x 3
        Q = cov(dHn a) + st^2 Hn[:, :2] Hn[:, :2]^T, where cov(dHn a)_ij = a^T C_ij a over the 3 x 3 blocks
        C_ij of the parameters' covariance (h33 = 1 has none). As a3 = 1, the first target sigma's term
        joins the blocks' corners, and one (N, 9) @ (9, 9) product gives every target's Q. The target's
        term is the same 3 x 3 K for every target, so each further sigma adds (st^2 - st0^2) G K G^T / w^2.
        """
        xy = np.atleast_2d(np.asarray(xy_px, float))
        n = len(xy)
        Hn = np.append(self._h_n, 1.0).reshape(3, 3)
        C = self._parameter_covs(sigma_landmark_px, sigma_landmark_m, fixes_alone)
        Cq = _q_blocks(C[0])
        K = (Hn[:, :2] @ Hn[:, :2].T) * (self._sp * self._sp)             # a target's term per px^2
        s0 = float(sigmas_target_px[0])
        Cq[8] += (s0 * s0) * K.ravel()
        a = np.ones((n, 3))                                               # targets, normalised, homogeneous
        a[:, :2] = xy * self._sp + self._Tp[:2, 2]
        q = a @ Hn.T
        w = q[:, 2:]
        XY = q[:, :2] / w
        scale = ((w * self._sg) ** 2)[:, :, None]
        aa = (a[:, :, None] * a[:, None, :]).reshape(n, 9)

        def ground_cov(Cq_: np.ndarray) -> np.ndarray:                    # G Q G^T / w^2, m^2
            Q = (aa @ Cq_).reshape(n, 3, 3)
            GQ = Q[:, :2] - XY[:, :, None] * Q[:, 2:]                     # G Q
            return (GQ[:, :, :2] - GQ[:, :, 2:] * XY[:, None, :]) / scale

        covs = [ground_cov(Cq)]
        if len(sigmas_target_px) > 1:
            GK = K[None, :2] - XY[:, :, None] * K[None, 2:]               # G K
            per_px2 = (GK[:, :, :2] - GK[:, :, 2:] * XY[:, None, :]) / scale
            covs += [covs[0] + (float(s) * float(s) - s0 * s0) * per_px2 for s in sigmas_target_px[1:]]
        if fixes_alone:
            covs.append(ground_cov(_q_blocks(C[1])))
        en = XY / self._sg + self._Tg_inv[:2, 2]
        if n and not w.min() > 1e-12:                                     # beyond the horizon: no point
            bad = ~(w[:, 0] > 1e-12)
            en[bad] = np.nan
            for c in covs:
                c[bad] = np.nan
        return en, covs

    def _parameter_covs(self, sigma_landmark_px, sigma_landmark_m, fixes_alone: bool = False) -> list[np.ndarray]:
        """(8, 8) covariance of the normalised parameters from the inliers' pixel and ground noise, through
        the least-squares solution (Gauss-Newton: dh = -A^+ (dr/dz) dz); with ``fixes_alone`` also the
        ground noise's alone."""
        sp = self._per_inlier(sigma_landmark_px, self._sp)
        sg = self._per_inlier(sigma_landmark_m, self._sg)
        var_px = np.array([v for p in sp for v in (p * p, p * p, 0.0, 0.0)])   # x, y, X, Y per landmark
        var_g = np.array([v for g in sg for v in (0.0, 0.0, g * g, g * g)])
        J_h = self._A_pinv @ self._dr_dz                   # (8, 4m), less its sign: J var J^T is the same
        covs = [(J_h * (var_px + var_g)) @ J_h.T]
        if fixes_alone:
            covs.append((J_h * var_g) @ J_h.T)
        return covs

    def _per_inlier(self, v, scale: float) -> list[float]:
        """A scalar or a (n,) value per landmark given to the fit -> m plain floats over the inliers, scaled."""
        a = np.asarray(v, float)
        if a.ndim == 0:
            return [float(a) * scale] * (self._A_pinv.shape[1] // 2)
        a = a if a.shape == self.inliers.shape else np.broadcast_to(a, self.inliers.shape)
        return [x * scale for x in a[self.inliers].tolist()]


def _q_blocks(cov8: np.ndarray) -> np.ndarray:
    """The (9, 9) matrix that turns a target's a_k a_l into its Q_ij, from the parameters' (8, 8) covariance
    (h33 = 1 has none): rows a_k a_l, columns Q_ij."""
    C = np.zeros((9, 9))
    C[:8, :8] = cov8
    return C.reshape(3, 3, 3, 3).transpose(1, 3, 0, 2).reshape(9, 9)


def _apply(H: np.ndarray, pts) -> np.ndarray:
    p = np.asarray(pts, float).reshape(-1, 2)
    q = p @ H[:, :2].T + H[:, 2]                  # (N, 3) homogeneous
    w = q[:, 2:]
    ok = w > 1e-12                                # in front of the camera (or of the ground plane)
    if ok.all():
        return q[:, :2] / w
    return np.divide(q[:, :2], w, out=np.full((len(p), 2), np.nan), where=ok)


class _Solved(NamedTuple):
    """A transform solved from landmarks, with what covariance propagation needs."""

    H: np.ndarray           # ground from pixels, H33 = 1
    h: np.ndarray           # (8,) normalised parameters
    A_pinv: np.ndarray      # (8, 2m) pseudo-inverse of the normalised design matrix
    pn: list                # m normalised pixels (u, v)
    gn: list                # m normalised ground points (X, Y)
    sp: float
    sg: float
    Tp: np.ndarray
    Tg_inv: np.ndarray


def _solve(img: list, gnd: list) -> _Solved | FitFailure:
    """Normalise the landmarks, solve A h = b and de-normalise: H = Tg^-1 Hn Tp."""
    sp, opx, opy = _hartley(img)
    sg, ogx, ogy = _hartley(gnd)
    pn = [(x * sp + opx, y * sp + opy) for x, y in img]
    gn = [(x * sg + ogx, y * sg + ogy) for x, y in gnd]
    design, b = [], []
    for (x, y), (X, Y) in zip(pn, gn):        # the east and the north equation of each landmark
        design += (x, y, 1.0, 0.0, 0.0, 0.0, -X * x, -X * y, 0.0, 0.0, 0.0, x, y, 1.0, -Y * x, -Y * y)
        b += (X, Y)
    A = np.array(design).reshape(-1, 8)
    # One thin SVD gives the condition number, the solution and the pseudo-inverse.
    U, sv, Vt = np.linalg.svd(A, full_matrices=False)
    if sv[-1] <= sv[0] / _COND_MAX:
        return FitFailure(FailureReason.ILL_CONDITIONED, f"condition number {sv[0] / max(sv[-1], 1e-300):.3g}")
    A_pinv = (Vt.T / sv) @ U.T
    h_n = A_pinv @ np.array(b)
    h = h_n.tolist()
    Hn = (h[0:3], h[3:6], (h[6], h[7], 1.0))
    # Hn Tp with Tp = [[sp, 0, opx], [0, sp, opy], [0, 0, 1]], then Tg^-1 = [[1/sg, 0, tx], [0, 1/sg, ty], [0, 0, 1]]
    M = [(r0 * sp, r1 * sp, r0 * opx + r1 * opy + r2) for r0, r1, r2 in Hn]
    tx, ty = -ogx / sg, -ogy / sg
    H = [[M[0][c] / sg + tx * M[2][c] for c in range(3)], [M[1][c] / sg + ty * M[2][c] for c in range(3)], list(M[2])]
    h22 = H[2][2]
    if not all(isfinite(v) for row in H for v in row) or abs(h22) < 1e-300:
        return FitFailure(FailureReason.ILL_CONDITIONED, "the solved transform is not finite")
    Tp = np.array([[sp, 0.0, opx], [0.0, sp, opy], [0.0, 0.0, 1.0]])
    Tg_inv = np.array([[1 / sg, 0, tx], [0, 1 / sg, ty], [0, 0, 1.0]])
    return _Solved(np.array([[v / h22 for v in row] for row in H]), h_n, A_pinv, pn, gn, sp, sg, Tp, Tg_inv)


_DR_INDEX: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _dr_index(m: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the six entries per landmark of the residual Jacobian (fit_homography)."""
    if m not in _DR_INDEX:
        i = np.repeat(np.arange(m), 6)
        _DR_INDEX[m] = (2 * i + np.tile([0, 0, 0, 1, 1, 1], m), 4 * i + np.tile([0, 1, 2, 0, 1, 3], m))
    return _DR_INDEX[m]


def fit_homography(xy_px, en_m, *, min_sep_px: float = 0.5, min_sep_m: float = 0.05,
                   inliers: np.ndarray | None = None, quality: FitQuality | None = None) -> Homography | FitFailure:
    """Fit ground = H(image) from n >= 4 correspondences: exact for 4, least squares for more."""
    p_all = np.asarray(xy_px, float)
    g_all = np.asarray(en_m, float)
    mask = None if inliers is None else np.asarray(inliers, bool)
    picked = _landmarks(p_all, g_all, mask)
    if isinstance(picked, FitFailure):
        return picked
    bad = _check_geometry(*picked, min_sep_px, min_sep_m)
    if bad is not None:
        return bad
    s = _solve(*picked)
    if isinstance(s, FitFailure):
        return s
    h0, h1, h2, h3, h4, h5, h6, h7 = s.h.tolist()
    # residual Jacobian wrt z = (x, y, X, Y) per landmark, block diagonal (Gauss-Newton): landmark i's
    # rows 2i, 2i + 1 and columns 4i .. 4i + 3 hold [[h0 - X h6, h1 - X h7, -w, 0], [h3 - Y h6, h4 - Y h7, 0, -w]]
    m = len(s.pn)
    entries = []
    for (x, y), (X, Y) in zip(s.pn, s.gn):
        w = h6 * x + h7 * y + 1.0
        entries += (h0 - X * h6, h1 - X * h7, -w, h3 - Y * h6, h4 - Y * h7, -w)
    dr = np.zeros((2 * m, 4 * m))
    dr[_dr_index(m)] = entries
    # every landmark's distance from where its pixel maps, outliers too (beyond the horizon: NaN)
    img, gnd = picked if mask is None else (p_all.tolist(), g_all.tolist())
    res = [sqrt((e - X) * (e - X) + (n - Y) * (n - Y)) for (e, n), (X, Y) in zip(map_few(s.H, img), gnd)]
    inl = np.ones(len(res), bool) if mask is None else mask.copy()
    rms = 0.0 if m == 4 else sqrt(sum(r * r for r, i in zip(res, inl.tolist()) if i) / m)
    q = quality or (FitQuality.EXACT if m == 4 else FitQuality.LEAST_SQUARES)
    return Homography(s.H, _inverse_scaled(s.H), q, inl, rms, np.array(res), s.h, s.A_pinv, dr, s.Tp, s.sp, s.sg,
                      s.Tg_inv)


def _inverse_scaled(H: np.ndarray) -> np.ndarray:
    """inv(H) scaled by |its H22| only: inv(H) [g; 1] = [p; 1] / w(p), so w > 0 marks points in front.
    For a 3 x 3 that is sign(det H) adj(H) / |adj(H)22| (the determinant cancels)."""
    (a, b, c), (d, e, f), (g, h, k) = H.tolist()
    adj = ((e * k - f * h, c * h - b * k, b * f - c * e),
           (f * g - d * k, a * k - c * g, c * d - a * f),
           (d * h - e * g, b * g - a * h, a * e - b * d))
    det = a * adj[0][0] + b * adj[1][0] + c * adj[2][0]
    if det == 0 or adj[2][2] == 0 or not isfinite(det):
        Hinv = np.linalg.inv(H)                     # singular: numpy says so
        return Hinv / abs(Hinv[2, 2])
    scale = (1.0 if det > 0 else -1.0) / abs(adj[2][2])
    return np.array([[v * scale for v in row] for row in adj])


def _hypothesis_residuals(p: np.ndarray, g: np.ndarray, sel: np.ndarray, min_sep_px: float,
                          min_sep_m: float) -> np.ndarray | None:
    """(n,) distance of every landmark from where the exact fit of the ``sel`` four maps it, or None when
    those four cannot be fitted. Computed exactly as the search always did (numpy, SVD): when consensus
    sets tie, round-off in these residuals picks one (fit_homography_robust), and other arithmetic's
    round-off would pick another."""
    picked = _landmarks(p, g, sel)
    if isinstance(picked, FitFailure) or _check_geometry(*picked, min_sep_px, min_sep_m) is not None:
        return None
    _, sp, Tp = _normaliser(p[sel])
    _, sg, Tg = _normaliser(g[sel])
    A, b = _design(p[sel] * sp + Tp[:2, 2], g[sel] * sg + Tg[:2, 2])
    U, sv, Vt = np.linalg.svd(A, full_matrices=False)
    if sv[-1] <= sv[0] / _COND_MAX:
        return None
    h = ((Vt.T / sv) @ U.T) @ b
    Tg_inv = np.array([[1 / sg, 0, -Tg[0, 2] / sg], [0, 1 / sg, -Tg[1, 2] / sg], [0, 0, 1.0]])
    H = Tg_inv @ np.append(h, 1.0).reshape(3, 3) @ Tp
    if not np.isfinite(H).all() or abs(H[2, 2]) < 1e-300:
        return None
    resid = _apply(H / H[2, 2], p) - g
    return np.sqrt(resid[:, 0] ** 2 + resid[:, 1] ** 2)


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
            err = _hypothesis_residuals(p, g, sel, min_sep_px, min_sep_m)
            if err is None:
                continue
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
    tr, disc = 0.5 * (a + d), np.sqrt((0.5 * (a - d)) ** 2 + b * b)
    lmax, lmin = tr + disc, np.maximum(tr - disc, 0.0)
    k = np.sqrt(np.divide(lmin, lmax, out=np.ones_like(lmax), where=lmax > 0))
    return np.sqrt(lmax) * np.interp(k, _K_GRID, _R95_GRID)
