"""A live loopback team (uvteam demo --frames sensor), read three ways at once:

- with only zenoh and msgpack (wire_reader.py, which refuses to import uvteam), through an endpoint the
  demo's router was told to listen on (uvteam demo -l ENDPOINT --cfg KEY:VALUE): every key's zenoh
  encoding names the schema its payload carries, and the payloads validate against the published
  JSON Schemas (docs/schemas, with jsonschema);
- recorded by the demo itself (--record) to MCAP: mcap's own reader, the same keys, every crowds
  message the localizer published;
- that recording through a fresh localizer (uvteam replay --localizer).
"""

import json
import subprocess
import sys
from pathlib import Path

import jsonschema
import pytest
from mcap.reader import make_reader

from uvteam.io.ports import free_port

pytestmark = pytest.mark.integration
ROOT = Path(__file__).resolve().parents[2]
SCHEMAS = ROOT / "docs" / "schemas"
TOPICS = {"fix", "plan", "detections", "sensor", "crowds", "status", "truth"}


@pytest.fixture(scope="module")
def live_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("wire")
    rec, summary, wire = d / "demo.mcap", d / "summary.json", d / "wire.json"
    endpoint = f"tcp/127.0.0.1:{free_port()}"   # the demo's router also listens here (-l): the third party's door
    demo = subprocess.Popen([sys.executable, "-m", "uvteam", "demo", "--frames", "sensor", "--duration", "8", "--quiet",
                             "--record", str(rec), "--json", str(summary), "--workdir", str(d / "work"),
                             "-l", endpoint, "--cfg", "transport/link/tx/lease:4000"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=d)
    reader = None
    try:
        first = demo.stdout.readline()
        reader = subprocess.Popen([sys.executable, str(Path(__file__).with_name("wire_reader.py")), endpoint, "demo",
                                   "16", str(wire)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        out, _ = demo.communicate(timeout=120)
        r_out, _ = reader.communicate(timeout=60)
    finally:
        for p in (demo, reader):
            if p is not None and p.poll() is None:
                p.kill()
                p.wait()
    assert demo.returncode == 0, first + out
    assert reader.returncode == 0, r_out
    return {"mcap": rec, "summary": json.loads(summary.read_text()), "wire": json.loads(wire.read_text()),
            "demo_out": first + out}


def test_every_key_decodes_with_zenoh_and_msgpack_alone(live_run):
    wire = live_run["wire"]
    topics = {k.split("/")[3] for k in wire}
    assert TOPICS <= topics, topics
    for key, s in wire.items():
        assert s["bad"] == 0 and s["count"] > 0, key
        assert len(s["schemas"]) == 1, (key, s["schemas"])
        # zenoh's encoding names the payload's schema: application/msgpack;<name>/<version>
        assert s["encodings"] == [f"application/msgpack;{s['schemas'][0]}"], (key, s["encodings"])
        schema = json.loads((SCHEMAS / (s["schemas"][0].replace("/", "-") + ".schema.json")).read_text())
        for data in s["payloads"]:
            jsonschema.Draft202012Validator(schema).validate(data)


def test_the_demo_recording_opens_in_mcaps_reader(live_run):
    with open(live_run["mcap"], "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        counts: dict[str, int] = {}
        for schema, channel, _msg in reader.iter_messages():
            if channel.message_encoding == "msgpack":
                assert schema.name == channel.metadata["zenoh_encoding"].split(";")[1]
                counts[channel.topic] = counts.get(channel.topic, 0) + 1
        names = {m.name for m in reader.iter_metadata()}
    assert set(counts) == set(live_run["wire"])             # every key the third party saw
    published = live_run["summary"]["summary"]["metrics"]["loc1"]["crowds_published"]
    assert counts["uvteam/demo/loc1/crowds"] == published    # every crowds message the localizer sent
    assert {"uvteam", "uvteam.config.loc1", "uvteam.config.uav1", "uvteam.config.ugv1"} <= names


def test_replaying_the_live_recording_through_a_fresh_localizer(live_run):
    from uvteam.io.recording import read_recording
    from uvteam.replay import localizer_config_for, replay_localizer

    rec = read_recording(live_run["mcap"])
    report = replay_localizer(rec, localizer_config_for(rec))
    assert report.recorded == live_run["summary"]["summary"]["metrics"]["loc1"]["crowds_published"]
    # the recorder is another process: it sees fixes later and in another order than the localizer did,
    # so frames can differ; the crowds it reproduces are where the recorded ones are
    gaps = sorted(report.gaps_m())
    print(report.summary())
    assert report.no_detections == 0
    assert not gaps or gaps[len(gaps) // 2] < 0.1     # measured: 2-3 mm
