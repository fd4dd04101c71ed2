"""Frames on the bus and frame sources: codec round trips, refusals, a video file's own timeline."""

import threading

import cv2
import numpy as np
import pytest

from uvteam.errors import MessageError
from uvteam.frames import FrameError, encode_frame, frame_pixels
from uvteam.io.video import open_source
from uvteam.messages import Frame, decode, encode


def _img(h=72, w=128, seed=0):
    return np.random.default_rng(seed).integers(0, 256, (h, w, 3), dtype=np.uint8)


def test_raw_frame_round_trips_exactly_through_the_wire():
    img = _img()
    fr = decode(Frame, encode(encode_frame("uav1", 1700000000.25, 7, img)))
    assert (fr.encoding, fr.width_px, fr.height_px, fr.frame_seq, fr.stamp_s) == ("bgr8", 128, 72, 7, 1700000000.25)
    assert np.array_equal(frame_pixels(fr), img)


def test_jpeg_frame_round_trips_closely():
    img = cv2.GaussianBlur(_img(), (0, 0), 2.0)   # JPEG is for natural images
    fr = decode(Frame, encode(encode_frame("uav1", 1.0, 1, img, jpeg_quality=95)))
    assert fr.encoding == "jpeg" and len(fr.data) < img.nbytes
    assert np.abs(frame_pixels(fr).astype(int) - img).mean() < 2.0


@pytest.mark.parametrize(
    "frame, why",
    [
        (Frame("uav1", 1.0, 1, 128, 72, "bgr8", b"\x00" * 99), "needs"),          # too few bytes
        (Frame("uav1", 1.0, 1, 0, 72, "bgr8", b""), "needs"),                      # no size
        (Frame("uav1", 1.0, 1, 128, 72, "jpeg", b"not a jpeg"), "not a JPEG"),
        (Frame("uav1", 1.0, 1, 64, 72, "jpeg",                                      # size differs from the header
               cv2.imencode(".jpg", _img())[1].tobytes()), "frame says"),
        (Frame("uav1", 1.0, 1, 128, 72, "h265", b"\x00"), "unknown encoding"),
    ],
)
def test_frames_that_do_not_make_their_image_are_refused(frame, why):
    with pytest.raises(FrameError, match=why):
        frame_pixels(frame)


def test_frame_data_must_be_bytes_on_the_wire():
    raw = encode(Frame("uav1", 1.0, 1, 2, 1, "bgr8", b"\x00" * 6))
    import msgpack
    env = msgpack.unpackb(raw)
    env["data"]["data"] = "abcdef"
    with pytest.raises(MessageError, match="expected bytes"):
        decode(Frame, msgpack.packb(env))


def test_video_file_source_stamps_frames_on_its_own_timeline(tmp_path):
    path = tmp_path / "clip.avi"
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (160, 120))
    for k in range(10):
        vw.write(np.full((120, 160, 3), 20 * k, np.uint8))
    vw.release()
    clock = iter(np.arange(1000.0, 2000.0, 0.001))   # a host clock that barely moves
    stop = threading.Event()
    with open_source(str(path), pace=False, clock=lambda: next(clock)) as src:
        got = list(src.stream(stop))
    assert len(got) == 10
    stamps = np.array([s for s, _ in got])
    np.testing.assert_allclose(np.diff(stamps), 0.05, atol=1e-9)   # 20 fps, whatever the host clock did
    assert got[3][1].shape == (120, 160, 3) and abs(int(got[3][1].mean()) - 60) <= 3


def test_missing_file_and_unopenable_device_are_errors():
    with pytest.raises(FrameError, match="no such file"):
        open_source("/nonexistent/clip.mp4")
    with pytest.raises(FrameError, match="could not be opened"):
        open_source("device:97")
