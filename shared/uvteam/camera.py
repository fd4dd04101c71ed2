"""Pinhole camera looking down from the UAV: ground (ENU metres) <-> image pixels.

Camera axes: x right, y down (image), z along the optical axis. At yaw 0, roll 0, pitch 0 the camera
looks straight down with the top of the image towards north, so image right is east. ``yaw_deg``
turns the image top clockwise from north; ``roll_deg``/``pitch_deg`` tilt the optical axis about the
camera's x and y axes (gimbal residuals). No lens distortion.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import radians, tan

import numpy as np

__all__ = ["PinholeCamera", "CameraPose", "R_cam_from_enu"]


@dataclass(frozen=True, slots=True)
class PinholeCamera:
    width_px: int
    height_px: int
    hfov_deg: float

    def __post_init__(self) -> None:
        if self.width_px <= 0 or self.height_px <= 0:
            raise ValueError(f"image size must be positive, got {self.width_px}x{self.height_px}")
        if not 0.0 < self.hfov_deg < 180.0:
            raise ValueError(f"hfov_deg must be in (0, 180), got {self.hfov_deg}")

    @property
    def focal_px(self) -> float:
        return (self.width_px / 2.0) / tan(radians(self.hfov_deg) / 2.0)

    @property
    def K(self) -> np.ndarray:
        f = self.focal_px
        return np.array([[f, 0.0, self.width_px / 2.0], [0.0, f, self.height_px / 2.0], [0.0, 0.0, 1.0]])

    def footprint_m(self, alt_agl_m: float) -> tuple[float, float]:
        """Ground width and height seen from a nadir camera at this altitude."""
        s = alt_agl_m / self.focal_px
        return self.width_px * s, self.height_px * s


@dataclass(frozen=True, slots=True)
class CameraPose:
    east_m: float
    north_m: float
    up_m: float            # height of the camera above the ENU origin's plane
    yaw_deg: float = 0.0
    roll_deg: float = 0.0
    pitch_deg: float = 0.0


def R_cam_from_enu(pose: CameraPose) -> np.ndarray:
    nadir = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    y = radians(pose.yaw_deg)
    # yaw: the image top turns clockwise from north, i.e. the world is seen rotated anticlockwise
    Rz = np.array([[np.cos(y), -np.sin(y), 0.0], [np.sin(y), np.cos(y), 0.0], [0.0, 0.0, 1.0]])
    r, p = radians(pose.roll_deg), radians(pose.pitch_deg)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(r), -np.sin(r)], [0.0, np.sin(r), np.cos(r)]])
    Ry = np.array([[np.cos(p), 0.0, np.sin(p)], [0.0, 1.0, 0.0], [-np.sin(p), 0.0, np.cos(p)]])
    return Rx @ Ry @ nadir @ Rz


def project(camera: PinholeCamera, pose: CameraPose, enu_m) -> np.ndarray:
    """(N, 3) or (N, 2) ENU points (up = 0 when absent) -> (N, 2) pixels; behind the camera: NaN."""
    P = np.atleast_2d(np.asarray(enu_m, float))
    if P.shape[1] == 2:
        P = np.column_stack([P, np.zeros(len(P))])
    c = np.array([pose.east_m, pose.north_m, pose.up_m])
    pc = (P - c) @ R_cam_from_enu(pose).T
    f = camera.focal_px
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = np.column_stack([f * pc[:, 0] / pc[:, 2] + camera.width_px / 2.0,
                              f * pc[:, 1] / pc[:, 2] + camera.height_px / 2.0])
    uv[pc[:, 2] <= 1e-6] = np.nan
    return uv


def H_px_from_ground(camera: PinholeCamera, pose: CameraPose) -> np.ndarray:
    """The exact image<-ground-plane (up = 0) homography of this camera: K R [e1 e2 -R^T... ]."""
    R = R_cam_from_enu(pose)
    c = np.array([pose.east_m, pose.north_m, pose.up_m])
    t = -R @ c
    H = camera.K @ np.column_stack([R[:, 0], R[:, 1], t])
    return H / H[2, 2]


__all__ += ["project", "H_px_from_ground"]
