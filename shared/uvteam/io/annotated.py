"""Where the annotated camera goes: an MJPEG stream over HTTP and a video file. I/O for the UAV shell.

:class:`MjpegServer` serves the newest image, JPEG-encoded once per image and only while someone
watches:

    GET /             a page with the stream (open it in a browser)
    GET /stream.mjpg  multipart/x-mixed-replace MJPEG: browsers, VLC, ffplay, OpenCV read it
    GET /frame.jpg    the newest image, once

A page bound to loopback answers loopback names only (as ``uvteam map`` does). :class:`VideoFileWriter`
writes every image to an .mp4 (MPEG-4 Part 2, "mp4v") or .avi (Motion JPEG) with OpenCV, at the frame
rate the images' capture times show.
"""

from __future__ import annotations

import logging
import socket
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import urlsplit

import cv2
import numpy as np

__all__ = ["MjpegServer", "VideoFileWriter", "BOUNDARY"]

log = logging.getLogger(__name__)
BOUNDARY = "uvteamframe"
_LOOPBACK = {"127.0.0.1", "localhost", "::1"}
_PAGE = """<!doctype html><html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>body{{margin:0;background:#111;color:#ddd;font:13px sans-serif}}img{{max-width:100%;display:block;margin:auto}}</style>
</head><body><img src="stream.mjpg" alt="{title}"></body></html>"""


class MjpegServer(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, addr: tuple[str, int], *, title: str = "what the UAV sees", jpeg_quality: int = 80) -> None:
        self.address_family = socket.AF_INET6 if ":" in addr[0] else socket.AF_INET
        super().__init__(addr, _Handler)
        self.title, self.jpeg_quality = title, jpeg_quality
        self.loopback_only = addr[0] in _LOOPBACK or addr[0].startswith("127.")
        self._cv = threading.Condition()
        self._img: np.ndarray | None = None
        self._jpeg: bytes | None = None
        self._version = 0
        self._stopping = False
        self.watchers = 0
        self.sent = 0
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        return f"http://{f'[{host}]' if ':' in host else host}:{port}/"

    def start(self) -> "MjpegServer":
        self._thread = threading.Thread(target=self.serve_forever, name="mjpeg", daemon=True)
        self._thread.start()
        return self

    def publish(self, img: np.ndarray) -> None:
        """The newest image (BGR); encoded when a watcher asks for it."""
        with self._cv:
            self._img, self._jpeg = img, None
            self._version += 1
            self._cv.notify_all()

    def jpeg(self) -> tuple[int, bytes | None]:
        with self._cv:
            if self._jpeg is None and self._img is not None:
                ok, buf = cv2.imencode(".jpg", self._img, [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality])
                self._jpeg = buf.tobytes() if ok else None
            return self._version, self._jpeg

    def wait_newer(self, version: int, timeout_s: float) -> bool:
        with self._cv:
            return self._cv.wait_for(lambda: self._version != version or self._stopping, timeout=timeout_s) \
                and not self._stopping

    def close(self) -> None:
        with self._cv:
            self._stopping = True
            self._cv.notify_all()
        self.shutdown()
        self.server_close()
        if self._thread is not None:
            self._thread.join(timeout=5)


class _Handler(BaseHTTPRequestHandler):
    server: MjpegServer
    protocol_version = "HTTP/1.1"

    def log_message(self, fmt: str, *args) -> None:
        log.debug("%s " + fmt, self.address_string(), *args)

    def _send(self, status: int, body: bytes, ctype: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def do_GET(self) -> None:
        host = self.headers.get("Host") or ""
        name = host[1:].split("]")[0] if host.startswith("[") else host.split(":")[0]
        if self.server.loopback_only and name not in _LOOPBACK and not name.startswith("127."):
            return self._send(403, b"this stream answers on loopback names only\n", "text/plain; charset=utf-8")
        path = urlsplit(self.path).path
        if path in ("/", "/index.html"):
            return self._send(200, _PAGE.format(title=self.server.title).encode(), "text/html; charset=utf-8")
        if path == "/frame.jpg":
            _, jpg = self.server.jpeg()
            if jpg is None:
                return self._send(503, b"no frame yet\n", "text/plain; charset=utf-8")
            return self._send(200, jpg, "image/jpeg")
        if path == "/stream.mjpg":
            return self._stream()
        return self._send(404, b"not found\n", "text/plain; charset=utf-8")

    def _stream(self) -> None:
        srv = self.server
        self.send_response(200)
        self.send_header("Content-Type", f"multipart/x-mixed-replace; boundary={BOUNDARY}")
        self.send_header("Cache-Control", "no-store")
        self.send_header("Connection", "close")
        self.end_headers()
        self.close_connection = True
        with srv._cv:
            srv.watchers += 1
        sent = -1
        try:
            while True:
                version, jpg = srv.jpeg()
                if jpg is not None and version != sent:
                    self.wfile.write(f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\nContent-Length: {len(jpg)}\r\n\r\n"
                                     .encode() + jpg + b"\r\n")
                    self.wfile.flush()
                    sent = version
                    srv.sent += 1
                if not srv.wait_newer(sent, 1.0) and srv._stopping:
                    break
        except (BrokenPipeError, ConnectionResetError, TimeoutError):
            pass                                   # the watcher went away
        finally:
            with srv._cv:
                srv.watchers -= 1


class VideoFileWriter:
    """Images to a video file; opened at the second image, at the rate the first two capture times give
    (1-60 fps; 10 when they give none), and at the first image's size (others are resized to it)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if self.path.suffix.lower() not in (".mp4", ".avi"):
            raise ValueError(f"{self.path}: expected an .mp4 or .avi file")
        self._w: cv2.VideoWriter | None = None
        self._first: tuple[float, np.ndarray] | None = None
        self.frames = 0
        self.fps = 0.0

    def write(self, stamp_s: float, img: np.ndarray) -> None:
        if self._w is None:
            if self._first is None:
                self._first = (stamp_s, img)
                return
            dt = stamp_s - self._first[0]
            self.fps = float(min(60.0, max(1.0, round(1.0 / dt, 2)))) if dt > 0 else 10.0
            self._open(self._first[1])
            self._put(self._first[1])
            self._first = None
        self._put(img)

    def _open(self, img: np.ndarray) -> None:
        h, w = img.shape[:2]
        fourcc = cv2.VideoWriter_fourcc(*("mp4v" if self.path.suffix.lower() == ".mp4" else "MJPG"))
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._w = cv2.VideoWriter(str(self.path), fourcc, self.fps, (w, h))
        if not self._w.isOpened():
            raise OSError(f"{self.path}: OpenCV cannot write this video")
        self._size = (w, h)

    def _put(self, img: np.ndarray) -> None:
        if (img.shape[1], img.shape[0]) != self._size:
            img = cv2.resize(img, self._size)
        self._w.write(img)
        self.frames += 1

    def close(self) -> None:
        if self._w is None and self._first is not None:   # a single image: one frame at 10 fps
            self.fps = 10.0
            self._open(self._first[1])
            self._put(self._first[1])
        if self._w is not None:
            self._w.release()
            self._w = None
