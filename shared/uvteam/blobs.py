"""What a UAV frame shows, as validated parallel arrays: motion blobs and roof-label landmarks. Pure.

One type from the motion detector, through the wire (:class:`uvteam.messages.Detections` carries them
as they are), to the localizer; in the style of supervision's ``Detections``: every field one array
with one row per blob, checked on construction, filtered with a boolean mask or an index array.

    blobs = Blobs(xy_px=np.array([[640.0, 360.0]]), xyxy_px=np.array([[630.0, 350.0, 650.0, 370.0]]),
                  area_px=np.array([120.0]), ugv=("",))
    crowds = blobs[np.array([u == "" for u in blobs.ugv])]

``ugv`` names what the detector recognised in a blob: the roof label's color inside the vision
pipeline, the UGV's id once the UAV service has relabelled it (:meth:`Blobs.relabel`), "" for none.
``v_px_s`` and ``sigma_v_px_s``, when the detector measures them (:mod:`uvteam.vision.blob_velocity`),
are each blob's walkers' velocity against the ground in the frame's pixels and its 1-sigma spread per
axis, a spread of 0 where it was not measured; no rows at all when the detector measures none.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Annotated, ClassVar

import numpy as np

__all__ = ["Blobs", "Landmarks", "Columns"]


@dataclass(frozen=True, slots=True)
class Columns:
    """Annotates an array field: ``n`` columns per row (0: a vector, one value per row)."""

    n: int


def _array(name: str, v, cols: int) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if cols == 0:
        a = a.reshape(-1) if a.size == 0 else a
        if a.ndim != 1:
            raise ValueError(f"{name}: expected a vector, got shape {a.shape}")
    else:
        a = a.reshape(0, cols) if a.size == 0 else a
        if a.ndim != 2 or a.shape[1] != cols:
            raise ValueError(f"{name}: expected shape (N, {cols}), got {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name}: values must be finite")
    return a


def _check_labels(name: str, labels, n: int) -> tuple[str, ...]:
    t = tuple(labels)
    if len(t) != n:
        raise ValueError(f"{name}: {len(t)} labels for {n} rows")
    if not all(isinstance(s, str) for s in t):
        raise ValueError(f"{name}: labels must be strings")
    return t


@dataclass(frozen=True, slots=True, eq=False)
class Blobs:
    """Motion blobs: centre, box (origin top-left, x0 <= x1, y0 <= y1), moving pixels, recognised UGV."""

    SCHEMA: ClassVar[str] = "blobs/2"
    xy_px: Annotated[np.ndarray, Columns(2)] = field(default_factory=lambda: np.empty((0, 2)))
    xyxy_px: Annotated[np.ndarray, Columns(4)] = field(default_factory=lambda: np.empty((0, 4)))
    area_px: Annotated[np.ndarray, Columns(0)] = field(default_factory=lambda: np.empty(0))
    ugv: tuple[str, ...] = ()
    # the walkers' velocity against the ground (px/s; no rows: not measured), its 1-sigma spread (0: not measured)
    v_px_s: Annotated[np.ndarray, Columns(2)] = field(default_factory=lambda: np.empty((0, 2)))
    sigma_v_px_s: Annotated[np.ndarray, Columns(0)] = field(default_factory=lambda: np.empty(0))

    def __post_init__(self) -> None:
        xy = _array("xy_px", self.xy_px, 2)
        box = _array("xyxy_px", self.xyxy_px, 4)
        area = _array("area_px", self.area_px, 0)
        n = len(xy)
        if len(box) != n or len(area) != n:
            raise ValueError(f"blobs: one row per blob in xy_px, xyxy_px and area_px, got {n} centres, {len(box)} boxes, "
                             f"{len(area)} areas")
        if (box[:, 2] < box[:, 0]).any() or (box[:, 3] < box[:, 1]).any():
            raise ValueError("xyxy_px: a box with x1 < x0 or y1 < y0")
        if (area < 0).any():
            raise ValueError("area_px: a negative area")
        ugv = _check_labels("ugv", self.ugv if self.ugv else ("",) * n, n)
        v, sv = _array("v_px_s", self.v_px_s, 2), _array("sigma_v_px_s", self.sigma_v_px_s, 0)
        if len(v) != len(sv) or len(v) not in (0, n):
            raise ValueError(f"v_px_s: none, or one row per blob in v_px_s and sigma_v_px_s, got {len(v)} and "
                             f"{len(sv)} for {n} blobs")
        if (sv < 0).any():
            raise ValueError("sigma_v_px_s: a negative spread")
        object.__setattr__(self, "v_px_s", v)
        object.__setattr__(self, "sigma_v_px_s", sv)
        object.__setattr__(self, "xy_px", xy)
        object.__setattr__(self, "xyxy_px", box)
        object.__setattr__(self, "area_px", area)
        object.__setattr__(self, "ugv", ugv)

    @staticmethod
    def empty() -> "Blobs":
        return Blobs()

    def __len__(self) -> int:
        return len(self.xy_px)

    def __getitem__(self, sel) -> "Blobs":
        """Rows by a boolean mask or an index array (a new Blobs)."""
        idx = np.flatnonzero(np.asarray(sel, bool)) if np.asarray(sel).dtype == bool else np.asarray(sel, int)
        idx = idx.reshape(-1)
        measured = len(self.v_px_s) > 0
        return Blobs(self.xy_px[idx], self.xyxy_px[idx], self.area_px[idx], tuple(self.ugv[i] for i in idx),
                     self.v_px_s[idx] if measured else self.v_px_s, self.sigma_v_px_s[idx] if measured else self.sigma_v_px_s)

    def relabel(self, names: Mapping[str, str]) -> "Blobs":
        """The same blobs with each label mapped through ``names`` (a label not in it becomes "")."""
        return replace(self, ugv=tuple(names.get(u, "") if u else "" for u in self.ugv))

    def velocity_of(self, i: int) -> tuple[np.ndarray, float] | None:
        """Blob ``i``'s walkers' velocity (px/s) and its 1-sigma spread per axis, None where not measured."""
        if not len(self.v_px_s) or not self.sigma_v_px_s[i] > 0:
            return None
        return self.v_px_s[i], float(self.sigma_v_px_s[i])

    def __eq__(self, other) -> bool:
        return (isinstance(other, Blobs) and self.ugv == other.ugv and np.array_equal(self.xy_px, other.xy_px)
                and np.array_equal(self.xyxy_px, other.xyxy_px) and np.array_equal(self.area_px, other.area_px)
                and np.array_equal(self.v_px_s, other.v_px_s) and np.array_equal(self.sigma_v_px_s, other.sigma_v_px_s))

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, slots=True, eq=False)
class Landmarks:
    """Roof labels found in a frame: one row per UGV (or color), its label's centre in pixels."""

    SCHEMA: ClassVar[str] = "landmarks/1"
    ugv: tuple[str, ...] = ()
    xy_px: Annotated[np.ndarray, Columns(2)] = field(default_factory=lambda: np.empty((0, 2)))

    def __post_init__(self) -> None:
        xy = _array("xy_px", self.xy_px, 2)
        ugv = _check_labels("ugv", self.ugv, len(xy))
        if any(not u for u in ugv) or len(set(ugv)) != len(ugv):
            raise ValueError("ugv: landmark names must be non-empty and unique")
        object.__setattr__(self, "xy_px", xy)
        object.__setattr__(self, "ugv", ugv)

    @staticmethod
    def from_dict(px_of: Mapping[str, tuple[float, float]]) -> "Landmarks":
        names = sorted(px_of)
        return Landmarks(tuple(names), np.array([px_of[u] for u in names], float).reshape(-1, 2))

    def as_dict(self) -> dict[str, tuple[float, float]]:
        return {u: (float(x), float(y)) for u, (x, y) in zip(self.ugv, self.xy_px)}

    def relabel(self, names: Mapping[str, str]) -> "Landmarks":
        """Each name mapped through ``names``; rows whose name is not in it are dropped (not our team's)."""
        keep = [i for i, u in enumerate(self.ugv) if u in names]
        return Landmarks(tuple(names[self.ugv[i]] for i in keep), self.xy_px[keep])

    def __len__(self) -> int:
        return len(self.ugv)

    def __eq__(self, other) -> bool:
        return isinstance(other, Landmarks) and self.ugv == other.ugv and np.array_equal(self.xy_px, other.xy_px)

    __hash__ = None  # type: ignore[assignment]
