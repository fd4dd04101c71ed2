"""Read a live uvteam team with nothing but zenoh and msgpack, as a third party would (docs/protocol.md).

    python wire_reader.py ENDPOINT TEAM SECONDS OUT.json

Subscribes to uvteam/<team>/** for SECONDS and writes, per key: the zenoh encodings seen, the schema
names in the payloads, the count, and the first three payloads' data maps (bytes as base64). Importing
anything named uvteam is refused, so this proves the protocol can be read without uvteam's code.
"""

import base64
import importlib.abc
import json
import sys
import threading
import time


class _NoUvteam(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "uvteam" or name.startswith(("uvteam.", "uvteam_")):
            raise ImportError(f"wire_reader must not import {name}")
        return None


sys.meta_path.insert(0, _NoUvteam())

import msgpack  # noqa: E402
import zenoh  # noqa: E402


def plain(v):
    if isinstance(v, bytes):      # JSON has no bytes: base64, as docs/protocol.md says
        return base64.b64encode(v).decode("ascii")
    if isinstance(v, dict):
        return {k: plain(x) for k, x in v.items()}
    if isinstance(v, list):
        return [plain(x) for x in v]
    return v


def main(endpoint: str, team: str, seconds: float, out: str) -> int:
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("connect/timeout_ms", "15000")      # the router may still be starting
    seen: dict[str, dict] = {}
    lock = threading.Lock()

    def on_sample(sample) -> None:
        key, enc = str(sample.key_expr), str(sample.encoding)
        msg = msgpack.unpackb(sample.payload.to_bytes(), raw=False)
        with lock:
            s = seen.setdefault(key, {"encodings": [], "schemas": [], "count": 0, "payloads": [], "bad": 0})
            if enc not in s["encodings"]:
                s["encodings"].append(enc)
            if not (isinstance(msg, dict) and set(msg) == {"schema", "data"}):
                s["bad"] += 1
                return
            if msg["schema"] not in s["schemas"]:
                s["schemas"].append(msg["schema"])
            s["count"] += 1
            if len(s["payloads"]) < 3:
                s["payloads"].append(plain(msg["data"]))

    with zenoh.open(conf) as session:
        session.declare_subscriber(f"uvteam/{team}/**", on_sample)
        time.sleep(seconds)
    with lock:
        with open(out, "w") as f:
            json.dump(seen, f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]))
