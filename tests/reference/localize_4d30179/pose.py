# FROZEN: uvteam/pose.py as it was at commit 4d30179 (before the localizer was made faster), the reference
# that uvteam_ground.bench_localize measures the product against and checks it equals. Do not edit.
"""The camera's pose as a prior and a fallback: image <-> ground through where the camera is and how it
looks, with what that is worth. Pure.

A :class:`uvteam.messages.CameraPoseReport` (position, height above ground, roll, pitch, yaw, each
with its 1-sigma) becomes a :class:`PosePrior` in a local east-north frame: the pinhole camera's exact
image <-> ground-plane homography (:func:`uvteam.camera.H_px_from_ground`) and a per-point 1-sigma.
A ray ``rho`` metres from the nadir point, from ``alt`` metres up, moves on the ground by
``alt * d_att * (1 + (rho/alt)^2)`` for a tilt error ``d_att`` (radians), ``rho * d_yaw`` for a yaw error,
``rho * d_alt / alt`` for a height error, and by the position error itself; the sigma is the root sum
of their squares (per axis, conservatively). Flat ground is assumed.

Used by the localizer to tell which landmark lies (a prior for :func:`uvteam.homography.fit_homography_robust`),
to flag a four-landmark fit that disagrees (SUSPECT), and to place crowds when fewer than four landmarks
are seen (POSE), and by the UAV to predict where each UGV's roof label must be.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uvteam.camera import CameraPose, PinholeCamera, H_px_from_ground
from uvteam.geo import LocalFrame

__all__ = ["PosePrior", "pose_prior"]


@dataclass(frozen=True, slots=True)
class PosePrior:
    H_ground_from_px: np.ndarray      # (3, 3)
    H_px_from_ground: np.ndarray      # (3, 3)
    camera_en_m: np.ndarray           # (2,) the point under the camera
    alt_agl_m: float
    sigma_position_m: float
    sigma_attitude_rad: float
    sigma_yaw_rad: float
    sigma_alt_m: float

    def px_to_ground(self, xy_px) -> np.ndarray:
        return _apply(self.H_ground_from_px, xy_px)

    def ground_to_px(self, en_m) -> np.ndarray:
        return _apply(self.H_px_from_ground, en_m)

    def sigma_m(self, en_m) -> np.ndarray:
        """(N,) 1-sigma per axis of ground points placed through this pose."""
        en = np.asarray(en_m, float).reshape(-1, 2)
        rho = np.sqrt(((en - self.camera_en_m) ** 2).sum(1))
        h = max(self.alt_agl_m, 1.0)
        return np.sqrt(self.sigma_position_m ** 2 + (h * self.sigma_attitude_rad * (1.0 + (rho / h) ** 2)) ** 2
                       + (rho * self.sigma_yaw_rad) ** 2 + (rho * self.sigma_alt_m / h) ** 2)


def _apply(H: np.ndarray, pts) -> np.ndarray:
    p = np.asarray(pts, float).reshape(-1, 2)
    q = p @ H[:, :2].T + H[:, 2]
    w = q[:, 2:]
    return np.divide(q[:, :2], w, out=np.full((len(p), 2), np.nan), where=w > 1e-12)


def pose_prior(report, frame: LocalFrame, width_px: int, height_px: int, focal_px: float) -> PosePrior | None:
    """The prior of a pose report in ``frame`` for an image of this size and focal length (None when the
    pose does not make a camera that sees the ground)."""
    if not (report.alt_agl_m > 1.0 and focal_px > 0):
        return None
    e, n = frame.wgs84_to_ground(report.lat_deg, report.lon_deg)
    hfov = math.degrees(2.0 * math.atan(width_px / 2.0 / focal_px))
    cam = PinholeCamera(int(width_px), int(height_px), hfov)
    pose = CameraPose(float(e), float(n), report.alt_agl_m, report.yaw_deg, report.roll_deg, report.pitch_deg)
    H_px = H_px_from_ground(cam, pose)
    try:
        H_g = np.linalg.inv(H_px)
    except np.linalg.LinAlgError:
        return None
    H_g = H_g / H_g[2, 2] if abs(H_g[2, 2]) > 1e-12 else H_g
    if H_g[2, 2] < 0:
        H_g = -H_g
    return PosePrior(H_g, H_px, np.array([float(e), float(n)]), report.alt_agl_m, report.sigma_position_m,
                     math.radians(report.sigma_attitude_deg), math.radians(report.sigma_yaw_deg), report.sigma_alt_m)
