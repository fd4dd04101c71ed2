"""The bus codec for camera frames (:class:`uvteam.messages.Frame`). Pure: bytes in, pixels out.

Frame sources (cameras, files, streams) are I/O: :mod:`uvteam.io.video`.
"""

from __future__ import annotations

import cv2
import numpy as np

from .messages import Frame

__all__ = ["encode_frame", "frame_pixels", "FrameError", "ENCODINGS"]

ENCODINGS = ("jpeg", "bgr8")


class FrameError(ValueError):
    """A frame that cannot be decoded, or a source that cannot be opened; says which and why."""


def encode_frame(vehicle: str, stamp_s: float, frame_seq: int, img: np.ndarray, jpeg_quality: int = 0) -> Frame:
    """An image (H, W, 3 uint8 BGR) -> a Frame: JPEG at ``jpeg_quality`` (1-100), raw BGR when 0."""
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] != 3:
        raise FrameError(f"expected an HxWx3 uint8 BGR image, got {img.dtype} {img.shape}")
    h, w = img.shape[:2]
    if jpeg_quality > 0:
        ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
        if not ok:
            raise FrameError("JPEG encoding failed")
        return Frame(vehicle, stamp_s, frame_seq, w, h, "jpeg", buf.tobytes())
    return Frame(vehicle, stamp_s, frame_seq, w, h, "bgr8", np.ascontiguousarray(img).tobytes())


def frame_pixels(frame: Frame) -> np.ndarray:
    """A Frame -> its BGR image, or FrameError when the bytes do not make the stated image."""
    if frame.encoding == "bgr8":
        n = frame.width_px * frame.height_px * 3
        if frame.width_px <= 0 or frame.height_px <= 0 or len(frame.data) != n:
            raise FrameError(f"bgr8 frame {frame.width_px}x{frame.height_px} needs {n} bytes, got {len(frame.data)}")
        return np.frombuffer(frame.data, np.uint8).reshape(frame.height_px, frame.width_px, 3)
    if frame.encoding == "jpeg":
        img = cv2.imdecode(np.frombuffer(frame.data, np.uint8), cv2.IMREAD_COLOR)
        if img is None:
            raise FrameError("not a JPEG image")
        if img.shape[:2] != (frame.height_px, frame.width_px):
            raise FrameError(f"JPEG is {img.shape[1]}x{img.shape[0]}, frame says {frame.width_px}x{frame.height_px}")
        return img
    raise FrameError(f"unknown encoding {frame.encoding!r}; known: {', '.join(ENCODINGS)}")


