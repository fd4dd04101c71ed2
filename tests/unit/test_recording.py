"""uvteam record / replay on the in-memory experiment: a recording read back by mcap's own reader (CRCs
checked), with schemas on every channel, Foxglove's map channels, and a fresh localizer that
reproduces every recorded crowds message byte for byte."""

import json

import jsonschema
import msgpack
import pytest
from mcap.reader import make_reader

from uvteam import keys, messages, protocol
from uvteam.formats import foxglove
from uvteam.io.recording import ns_of, read_recording, s_of
from uvteam.replay import first_difference, localizer_config_for, replay_localizer
from uvteam_ground.record import replay_main

from conftest import record_experiment

@pytest.fixture(scope="module")
def experiment_recording(tmp_path_factory):
    """8 s of the demo scenario in the experiment (the team's nodes over the in-memory bus), recorded."""
    path = tmp_path_factory.mktemp("rec") / "exp.mcap"
    team, _ = record_experiment(path, 1, 8.0, recorder="test")
    return path, team


@pytest.mark.parametrize("t_s", [1.7e9, 1_700_000_000.1, 1_796_149_026.880123, 1e-3, 9_999_999_999.999999])
def test_log_times_round_trip_exactly(t_s):
    # replay's clock reads the log time back: it must be the very float the recorder's clock gave
    assert s_of(ns_of(t_s)) == t_s


def test_mcap_reader_reads_it_with_schemas_on_every_channel(experiment_recording):
    path, team = experiment_recording
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        names = {m.name for m in reader.iter_metadata()}
        raw = fox = 0
        for schema, channel, msg in reader.iter_messages():
            assert schema is not None and schema.encoding == "jsonschema"
            if channel.message_encoding == "msgpack":
                # the raw payload, with its uvteam schema attached, which it validates against
                wire = msgpack.unpackb(msg.data)
                assert schema.name == wire["schema"] == channel.metadata["zenoh_encoding"].split(";")[1]
                if raw % 25 == 0:
                    jsonschema.validate(wire, json.loads(schema.data))
                raw += 1
            elif channel.topic.startswith("foxglove/"):
                assert channel.message_encoding == "json" and schema.name in foxglove.SCHEMAS
                jsonschema.validate(json.loads(msg.data), json.loads(schema.data))
                fox += 1
    assert names == {"uvteam", f"uvteam.config.{team.layout.localizer}"}
    topics = {c.topic for c in summary.channels.values()}
    assert f"uvteam/exp/{team.layout.localizer}/crowds" in topics and "foxglove/loc1/crowds" in topics
    assert {f"foxglove/{u}/location" for u in team.layout.ugvs} <= topics
    assert raw > 900 and fox > 500


def test_foxglove_channels_carry_the_messages(experiment_recording):
    path, _ = experiment_recording
    rec = read_recording(path)
    last_crowds = [r for r in rec.records if r.key.endswith("/crowds")][-1]
    msg = messages.decode(messages.Crowds, last_crowds.data)
    with open(path, "rb") as f:
        fox = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages(topics=["foxglove/loc1/crowds"])]
    fc = json.loads(fox[-1]["geojson"])
    points = [f for f in fc["features"] if f["geometry"]["type"] == "Point"]
    assert len(points) == len(msg.crowds) >= 1
    assert points[0]["geometry"]["coordinates"] == [round(msg.crowds[0].lon_deg, 7), round(msg.crowds[0].lat_deg, 7)]


def test_replayed_localizer_reproduces_every_crowds_message_byte_for_byte(experiment_recording):
    path, _ = experiment_recording
    rec = read_recording(path)
    report = replay_localizer(rec, localizer_config_for(rec))
    assert report.recorded == 81 and report.no_detections == 0
    assert report.exact, [first_difference(a, b) for _, a, b in report.differed[:3]]


def test_replay_notices_a_changed_localizer(experiment_recording):
    # the comparison is real: a localizer tuned otherwise does not reproduce the recording
    from dataclasses import replace

    path, _ = experiment_recording
    rec = read_recording(path)
    cfg = localizer_config_for(rec)
    cfg = replace(cfg, localizer=replace(cfg.localizer, gate_px=cfg.localizer.gate_px * 0.5, confirm_hits=1))
    report = replay_localizer(rec, cfg)
    assert not report.exact and report.differed
    assert "recorded" in first_difference(*report.differed[0][1:])


def test_replay_command_says_so(experiment_recording, capsys):
    path, _ = experiment_recording
    assert replay_main([str(path), "--localizer"]) == 0
    assert "81 crowds messages recorded, 81 reproduced byte for byte, 0 differ" in capsys.readouterr().out


def test_every_recorded_payload_validates_against_the_published_schema(experiment_recording):
    path, _ = experiment_recording
    validators = {c.SCHEMA: jsonschema.Draft202012Validator(protocol.json_schema(c)) for c in protocol.TOP_LEVEL}
    n = 0
    for r in read_recording(path).records:
        if r.encoding == "alive":
            continue
        wire = msgpack.unpackb(r.data)
        assert r.encoding == messages.encoding_of(messages.BY_TOPIC[keys.topic_of(r.key)])
        validators[wire["schema"]].validate(wire["data"])
        n += 1
    assert n > 900
