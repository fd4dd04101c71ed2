"""A uvteam recording read by Foxglove's own code: @mcap/core (the MCAP reader the Foxglove app uses,
TypeScript, independent of the Python writer) and @foxglove/schemas (Foxglove's published JSON
schemas for LocationFix and GeoJSON). Needs node and `make js` (npm packages in tests/js); skips and
says so without them."""

import json
import shutil
import subprocess
from pathlib import Path

import jsonschema
import pytest


from conftest import record_experiment

pytestmark = pytest.mark.integration
ROOT = Path(__file__).resolve().parents[2]
JS = ROOT / "tests" / "js"


@pytest.fixture(scope="module")
def foxglove_view(tmp_path_factory):
    if shutil.which("node") is None:
        pytest.skip("node is not installed (apt-get install nodejs npm; then make js)")
    if not (JS / "node_modules" / "@mcap" / "core").is_dir():
        pytest.skip("Foxglove's MCAP reader is not installed: run `make js` (npm install in tests/js)")
    path = tmp_path_factory.mktemp("fox") / "exp.mcap"
    _, counts = record_experiment(path, 2, 5.0)
    r = subprocess.run(["node", str(JS / "check_mcap.mjs"), str(path)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout), counts


def test_foxglove_reads_every_channel_with_its_schema(foxglove_view):
    view, counts = foxglove_view
    assert view["header"]["library"].startswith("uvteam ")
    schemas = {s["id"]: s for s in view["schemas"]}
    for ch in view["channels"]:
        s = schemas[ch["schemaId"]]                                   # every channel has its schema
        assert s["encoding"] == "jsonschema"
        json.loads(s["data"])
        if ch["messageEncoding"] == "msgpack":
            assert ch["metadata"]["zenoh_encoding"] == f"application/msgpack;{s['name']}"
    raw = sum(n for t, n in view["counts"].items() if t.startswith("uvteam/") and not t.endswith("/alive"))
    assert raw == sum(n for k, n in counts.items() if k != "alive")   # Foxglove's reader sees every payload
    assert {m["name"] for m in view["metadata"]} == {"uvteam", "uvteam.config.loc1"}


@pytest.mark.parametrize("name, topic", [
    ("foxglove.LocationFix", "foxglove/ugv1/location"),   # what the Map panel draws as a vehicle
    ("foxglove.LocationFix", "foxglove/uav1/location"),
    ("foxglove.GeoJSON", "foxglove/loc1/crowds"),         # what it draws as crowds
])
def test_map_channels_meet_foxgloves_own_schemas(foxglove_view, name, topic):
    view, _ = foxglove_view
    official = view["foxglove"][name]
    ours = json.loads(next(s["data"] for s in view["schemas"] if s["name"] == name))
    for field, spec in ours["properties"].items():               # our schema: a subset of theirs, same types
        assert field in official["properties"], field
        assert spec.get("type") == official["properties"][field].get("type"), field
    samples = view["samples"][topic]
    assert samples
    for msg in samples:
        jsonschema.validate(msg, official)
    if name == "foxglove.GeoJSON":
        assert json.loads(samples[-1]["geojson"])["type"] == "FeatureCollection"
