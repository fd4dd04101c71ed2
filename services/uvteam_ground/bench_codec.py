"""The message codec beside its yardstick (`uvteam bench codec`), one core, interleaved.

A realistic Detections message (20 blobs, 6 of them UGVs with their roof labels as landmarks):
``uvteam.messages.decode`` (unpack, validate every rule, build the arrays) against plain
``msgpack.unpackb`` of the same bytes (no validation, lists of lists), and ``uvteam.messages.encode``
(which validates what it sends) against plain ``msgpack.packb`` of the same wire data. Blocks of calls
alternate between the two, so the machine's drift hits both alike; the ratio is the figure to compare.
"""

from __future__ import annotations

import datetime
import time

import msgpack
import numpy as np

from uvteam.blobs import Blobs, Landmarks
from uvteam.messages import Detections, decode, encode

DECODE_TARGET_US = 10.0


def realistic_detections(n_blobs: int = 20, n_landmarks: int = 6, seed: int = 0) -> Detections:
    rng = np.random.default_rng(seed)
    xy = rng.uniform([40, 40], [1240, 680], (n_blobs, 2))
    half = rng.uniform(3, 30, (n_blobs, 2))
    ugvs = tuple(f"ugv{i + 1}" for i in range(n_landmarks))
    labels = ugvs + ("",) * (n_blobs - n_landmarks)
    return Detections("uav1", time.time(), 1234, 1280, 720, 50.0, 790.0,
                      Landmarks(ugvs, xy[:n_landmarks] + rng.normal(0, 0.5, (n_landmarks, 2))),
                      Blobs(xy, np.column_stack([xy - half, xy + half]), rng.uniform(30, 2000, n_blobs), labels),
                      0.5, 4.0, 6.3)


def interleaved(a, b, block: int = 500, blocks: int = 20) -> tuple[float, float]:
    """Microseconds per call of ``a`` and ``b``: blocks alternating A B, B A, ...; the best block's rate
    of each (the least disturbed by other processes)."""
    for _ in range(block):
        a()
        b()
    ta, tb = [], []
    for k in range(blocks):
        for f, acc in (((a, ta), (b, tb)) if k % 2 == 0 else ((b, tb), (a, ta))):
            t0 = time.perf_counter()
            for _ in range(block):
                f()
            acc.append((time.perf_counter() - t0) / block * 1e6)
    return min(ta), min(tb)


def run() -> dict:
    msg = realistic_detections()
    raw = encode(msg)
    wire = msgpack.unpackb(raw)
    assert decode(Detections, raw) == msg
    dec_us, unpack_us = interleaved(lambda: decode(Detections, raw), lambda: msgpack.unpackb(raw))
    enc_us, pack_us = interleaved(lambda: encode(msg), lambda: msgpack.packb(wire))
    today = datetime.date.today().isoformat()
    print(f"codec, Detections of 20 blobs and 6 landmarks ({len(raw)} bytes), interleaved on one core ({today}):")
    print(f"  decode: uvteam {dec_us:.1f} us, plain msgpack.unpackb {unpack_us:.1f} us: ratio {dec_us / unpack_us:.2f}x "
          f"the plain time (target <= {DECODE_TARGET_US:.0f} us)")
    print(f"  encode: uvteam {enc_us:.1f} us (validated), plain msgpack.packb {pack_us:.1f} us: ratio "
          f"{enc_us / pack_us:.2f}x the plain time")
    return {"decode_us": dec_us, "unpackb_us": unpack_us, "decode_ratio": dec_us / unpack_us,
            "encode_us": enc_us, "packb_us": pack_us, "encode_ratio": enc_us / pack_us, "bytes": len(raw)}
