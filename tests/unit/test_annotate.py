"""What the UAV sees: the drawing (pure), the MJPEG stream read by a client and decoded with cv2, and
the video file read back with cv2."""

import threading
import time
import urllib.request
from dataclasses import replace

import cv2
import numpy as np
import pytest

from uvteam.blobs import Blobs, Landmarks
from uvteam.geo import LocalFrame
from uvteam.io.annotated import BOUNDARY, MjpegServer, VideoFileWriter
from uvteam.messages import Crowd, Crowds, Detections
from uvteam.vision.annotate import annotate, place_crowds, ugv_bgr

W, H = 640, 360
ORIGIN = (31.4848, -111.5440)
M_PER_PX = 0.05        # a north-up camera: 20 px per metre, image centre at the origin


def px_to_latlon(x, y):
    f = LocalFrame(*ORIGIN)
    lat, lon = f.ground_to_wgs84(np.array([(x - W / 2) * M_PER_PX]), np.array([-(y - H / 2) * M_PER_PX]))
    return float(lat[0]), float(lon[0])


LANDMARKS_PX = {"ugv1": (100.0, 80.0), "ugv2": (540.0, 90.0), "ugv3": (520.0, 300.0), "ugv4": (90.0, 290.0),
                "ugv5": (320.0, 60.0)}
CROWD_BOX = (250.0, 150.0, 330.0, 210.0)


def detections(landmarks=LANDMARKS_PX):
    lm = Landmarks.from_dict(landmarks)
    blobs = Blobs(np.array([[290.0, 180.0], [100.0, 80.0]]), np.array([CROWD_BOX, [88.0, 68.0, 112.0, 92.0]]),
                  np.array([2400.0, 500.0]), ("", "ugv1"))
    return Detections("uav1", 1.7646e9, 42, W, H, 50.0, 790.0, lm, blobs, 0.5, 4.0, 6.0)


def crowds():
    lat, lon = px_to_latlon(290.0, 180.0)
    return Crowds("loc1", "uav1", 1.7646e9, "least_squares", tuple(LANDMARKS_PX), (),
                  (Crowd(7, lat, lon, (lat,) * 4, (lon,) * 4, 0.5, 0.1, 1.4, "least_squares", 0),))


def ugv_positions():
    return {u: px_to_latlon(*p) for u, p in LANDMARKS_PX.items()}


def outline(img, box, shift=0):
    """The pixels (B, G, R) on a box's outline, shifted right and down by ``shift``."""
    x0, y0, x1, y1 = (int(round(v)) + shift for v in box)
    pts = [(x, y0) for x in range(x0, x1 + 1)] + [(x, y1) for x in range(x0, x1 + 1)] + \
          [(x0, y) for y in range(y0, y1 + 1)] + [(x1, y) for y in range(y0, y1 + 1)]
    return img[[p[1] for p in pts], [p[0] for p in pts]].astype(int)


def red_fraction(img, box, shift=0):
    """The share of a box's outline that is clearly red (survives JPEG's and mp4v's 4:2:0 chroma)."""
    b, g, r = outline(img, box, shift).T
    return float(np.mean(r - np.maximum(g, b) > 60))


def test_a_crowd_blob_is_boxed_in_red_and_a_ugv_blob_in_its_colour():
    img = np.full((H, W, 3), 140, np.uint8)
    out = annotate(img, detections(), crowds(), ugv_positions())
    assert out is not img and (img == 140).all()                     # the input is left alone
    assert red_fraction(out, CROWD_BOX) > 0.95
    assert red_fraction(out, CROWD_BOX, shift=12) < 0.2              # and nowhere else
    ugv_box = outline(out, (88.0, 68.0, 112.0, 92.0))
    assert np.mean((ugv_box == ugv_bgr("ugv1")).all(axis=1)) > 0.5   # the UGV's blob in its colour (labels cross it)
    assert red_fraction(out, (88.0, 68.0, 112.0, 92.0)) == 0.0


@pytest.mark.parametrize("landmarks, placed", [
    (LANDMARKS_PX, True),                                             # five landmarks with fixes: the crowd is placed
    ({k: LANDMARKS_PX[k] for k in ("ugv1", "ugv2", "ugv3", "ugv4")}, True),   # four: still
    ({k: LANDMARKS_PX[k] for k in ("ugv1", "ugv2", "ugv3")}, False),  # three: listed, not placed
    ({}, False),                                                      # none seen
])
def test_crowds_are_placed_where_the_landmarks_say(landmarks, placed):
    tags = place_crowds(detections(landmarks), crowds(), ugv_positions())
    assert [t.crowd_id for t in tags] == [7]
    if placed:
        assert tags[0].xy_px == pytest.approx((290.0, 180.0), abs=0.5)
    else:
        assert tags[0].xy_px is None
    assert tags[0].unseen_s == 0.0


def test_a_crowd_not_seen_says_so():
    c = crowds()
    held = replace(c, crowds=(replace(c.crowds[0], unseen_s=1.5),))
    (tag,) = place_crowds(detections(), held, ugv_positions())
    assert tag.unseen_s == 1.5 and tag.xy_px == pytest.approx((290.0, 180.0), abs=0.5)
    assert not np.array_equal(annotate(np.zeros((H, W, 3), np.uint8), detections(), held, ugv_positions()),
                              annotate(np.zeros((H, W, 3), np.uint8), detections(), c, ugv_positions()))


def test_no_crowds_message_draws_detections_only():
    out = annotate(np.zeros((H, W, 3), np.uint8), detections(), None)
    assert red_fraction(out, CROWD_BOX) > 0.95


def test_a_bigger_image_than_the_detections_is_scaled():
    # detections in 640x360 pixels, drawn on the same frame at 1280x720
    out = annotate(np.zeros((2 * H, 2 * W, 3), np.uint8), detections(), crowds(), ugv_positions())
    assert red_fraction(out, tuple(2 * v for v in CROWD_BOX)) > 0.9


def read_mjpeg(url, n, timeout=10.0):
    """n frames from an MJPEG stream, decoded with cv2 (a client that knows nothing of uvteam)."""
    frames = []
    with urllib.request.urlopen(url, timeout=timeout) as r:
        assert r.headers["Content-Type"] == f"multipart/x-mixed-replace; boundary={BOUNDARY}"
        while len(frames) < n:
            line = r.readline()
            if line.strip() != f"--{BOUNDARY}".encode():
                continue
            headers = {}
            while (h := r.readline().strip()):
                k, v = h.decode().split(":", 1)
                headers[k.lower()] = v.strip()
            assert headers["content-type"] == "image/jpeg"
            data = r.read(int(headers["content-length"]))
            frames.append(cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR))
    return frames


def test_mjpeg_client_sees_the_box_where_the_blob_is():
    srv = MjpegServer(("127.0.0.1", 0)).start()
    stop = threading.Event()

    def feed():
        k = 0
        while not stop.is_set():
            img = np.full((H, W, 3), 120 + k % 40, np.uint8)
            srv.publish(annotate(img, detections(), crowds(), ugv_positions()))
            k += 1
            time.sleep(0.05)

    th = threading.Thread(target=feed, daemon=True)
    th.start()
    try:
        frames = read_mjpeg(srv.url + "stream.mjpg", 3)
        page = urllib.request.urlopen(srv.url, timeout=5).read().decode()
        assert 'src="stream.mjpg"' in page
    finally:
        stop.set()
        th.join(timeout=2)
        srv.close()
    assert len(frames) == 3 and all(f.shape == (H, W, 3) for f in frames)
    for f in frames:
        assert red_fraction(f, CROWD_BOX) > 0.9
        assert red_fraction(f, CROWD_BOX, shift=12) < 0.2


def test_nothing_is_encoded_while_nobody_watches():
    srv = MjpegServer(("127.0.0.1", 0))
    try:
        srv.publish(np.zeros((8, 8, 3), np.uint8))
        assert srv._jpeg is None and srv.watchers == 0
    finally:
        srv.server_close()


@pytest.mark.parametrize("suffix", [".mp4", ".avi"])
def test_video_file_reads_back(tmp_path, suffix):
    path = tmp_path / f"uav{suffix}"
    w = VideoFileWriter(path)
    for i in range(12):
        w.write(1.7646e9 + i * 0.1, annotate(np.full((H, W, 3), 100, np.uint8), detections(), crowds(), ugv_positions()))
    w.close()
    assert w.fps == 10.0 and w.frames == 12
    cap = cv2.VideoCapture(str(path))
    n, last = 0, None
    while True:
        ok, img = cap.read()
        if not ok:
            break
        n, last = n + 1, img
    cap.release()
    assert n == 12 and last.shape == (H, W, 3)
    assert red_fraction(last, CROWD_BOX) > 0.9
    assert red_fraction(last, CROWD_BOX, shift=12) < 0.2
