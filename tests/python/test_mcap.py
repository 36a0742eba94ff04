"""A recording of `wearnav record` read by a tool no one here wrote: the `mcap` package
from PyPI opens the file, and every payload decodes with wearnav_schemas.

Starts the demo (built by `cargo build --workspace`) on a free loopback port, records
5 s of it with `wearnav record`, then reads the file with ``mcap.reader.make_reader``.
"""

import json
import math
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

ROOT = Path(__file__).resolve().parents[2]
WEARNAV = ROOT / "target" / "debug" / "wearnav"
sys.path.insert(0, str(ROOT / "schemas" / "python"))

from wearnav_schemas import decode, encoding_schema  # noqa: E402

USER = "pymcap"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_listening(port, limit=20.0):
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.1)
    pytest.fail(f"nothing listens on port {port} after {limit} s")


@pytest.fixture
def recording(tmp_path):
    if not WEARNAV.exists():
        pytest.fail(f"{WEARNAV} missing: run `cargo build --workspace` first")
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    env = {**os.environ, "RUST_LOG": "warn"}
    demo = subprocess.Popen(
        [str(WEARNAV), "demo", "--duration", "12s", "--user", USER, "--listen", endpoint],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
    )
    try:
        wait_listening(port)
        out = tmp_path / "walk.mcap"
        run = subprocess.run(
            [str(WEARNAV), "record", "--user", USER, "--connect", endpoint, "--no-multicast",
             "--duration", "5s", "--out", str(out)],
            capture_output=True, text=True, timeout=60, env=env,
        )
        assert run.returncode == 0, run.stderr
        yield out
    finally:
        demo.kill()
        demo.wait()


def test_the_pypi_mcap_reader_opens_a_recording_and_every_payload_decodes(recording):
    with open(recording, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None, "no summary section: the recording did not finish"
        topics = {c.topic for c in summary.channels.values()}
        for suffix in ("perception/hazard", "perception/scan", "feedback/haptic"):
            assert f"wearnav/{USER}/{suffix}" in topics, sorted(topics)
        assert any(t.endswith("/depth") for t in topics), sorted(topics)
        for channel in summary.channels.values():
            if channel.topic.endswith("/json"):  # the JSON twin of a key, schemaless
                assert (channel.message_encoding, channel.schema_id) == ("json", 0)
                continue
            if channel.topic.endswith("/foxglove"):  # Foxglove's types: the next test
                continue
            assert channel.message_encoding == "wearnav-bincode"
            assert channel.metadata["zenoh_encoding"].endswith(summary.schemas[channel.schema_id].name)
        twins = {c.topic for c in summary.channels.values() if c.topic.endswith("/json")}
        always = {f"wearnav/{USER}/{k}/json" for k in ("perception/hazard", "feedback/haptic")}
        assert always <= twins <= always | {f"wearnav/{USER}/feedback/speech/json"}, twins

        last_seq = {}
        counts = {}
        wire = {}
        for schema, channel, message in reader.iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic.endswith("/foxglove"):
                continue
            if channel.message_encoding == "json":
                twin = json.loads(message.data)
                raw = wire[channel.topic[: -len("/json")]]
                # the Rust recorder's JSON is the Python decoder's serde view of the wire
                view = raw.to_json()
                assert (twin["header"], twin["body"]) == (view["header"], view["body"]), channel.topic
                continue
            decoded = decode(message.data)  # raises WireError on anything undecodable
            wire[channel.topic] = decoded
            assert schema.name == encoding_schema(decoded.schema), (schema.name, decoded.schema)
            assert message.sequence == decoded.header["seq"] & 0xFFFFFFFF
            assert message.publish_time == decoded.header["capture_ns"]
            stream = (channel.topic, decoded.header["sender"], decoded.header["session"])
            seq = decoded.header["seq"]
            if stream in last_seq:
                assert seq > last_seq[stream], f"{stream}: seq {last_seq[stream]} then {seq}"
            last_seq[stream] = seq

        stats = summary.statistics
        assert stats.message_count == sum(counts.values())
        for channel_id, channel in summary.channels.items():
            assert stats.channel_message_counts[channel_id] == counts[channel.topic]
        hazards = counts[f"wearnav/{USER}/perception/hazard"]
        assert counts[f"wearnav/{USER}/perception/hazard/json"] == hazards
        assert 90 <= hazards <= 190, f"{hazards} hazards in 5 s (30/s expected)"


def foxglove_json_schemas():
    """Foxglove's own JSON schemas, from its npm package @foxglove/schemas (installed by
    scripts/test: npm ci --prefix tests/browser)."""
    script = ('const j = require("@foxglove/schemas/dist/jsonschema");'
              'console.log(JSON.stringify({LaserScan: j.LaserScan, PoseInFrame: j.PoseInFrame,'
              ' PosesInFrame: j.PosesInFrame}));')
    run = subprocess.run(["node", "-e", script], cwd=ROOT / "tests" / "browser",
                         capture_output=True, text=True, timeout=60)
    if run.returncode != 0:
        pytest.fail(f"cannot load @foxglove/schemas (npm ci --prefix tests/browser): {run.stderr}")
    return json.loads(run.stdout)


def test_scan_pose_and_route_are_recorded_as_foxglove_types_that_validate_against_foxglove_schemas(recording):
    import jsonschema

    official = foxglove_json_schemas()
    with open(recording, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        wire = {}
        checked = {"foxglove.LaserScan": 0, "foxglove.PoseInFrame": 0, "foxglove.PosesInFrame": 0}
        for schema, channel, message in reader.iter_messages():
            if not channel.topic.endswith("/foxglove"):
                if channel.message_encoding == "wearnav-bincode":
                    wire[channel.topic] = decode(message.data)
                continue
            assert channel.message_encoding == "json"
            assert schema.encoding == "jsonschema" and schema.name in checked, schema.name
            assert json.loads(schema.data)["title"] == schema.name
            fox = json.loads(message.data)
            jsonschema.validate(fox, official[schema.name.split(".")[1]])
            source = wire[channel.topic[: -len("/foxglove")]]
            stamp = source.header["capture_ns"]
            assert (fox["timestamp"]["sec"], fox["timestamp"]["nsec"]) == divmod(stamp, 10**9)
            if schema.name == "foxglove.LaserScan":
                ranges = source.body["ranges_m"]
                assert len(fox["ranges"]) == len(ranges)
                assert fox["ranges"] == pytest.approx([r if r != float("inf") else 0.0 for r in ranges], abs=1e-6)
                first = source.body["angle_min_deg"]
                assert fox["start_angle"] == pytest.approx(math.radians(first), abs=1e-6)
            elif schema.name == "foxglove.PosesInFrame":
                route = source.body["route"]
                assert [(p["position"]["x"], p["position"]["y"]) for p in fox["poses"]] == pytest.approx(
                    [(p["x_m"], p["y_m"]) for p in route], abs=1e-5)
            else:
                pose, q = fox["pose"], fox["pose"]["orientation"]
                assert (pose["position"]["x"], pose["position"]["y"]) == pytest.approx(
                    (source.body["x_m"], source.body["y_m"]), abs=1e-5)
                yaw = 2 * math.atan2(q["z"], q["w"])
                assert math.remainder(yaw - source.body["yaw_rad"], 2 * math.pi) == pytest.approx(0, abs=1e-5)
            checked[schema.name] += 1
        assert checked["foxglove.LaserScan"] >= 90, checked  # 30 scans a second for 5 s
        assert checked["foxglove.PoseInFrame"] >= 10, checked
        assert checked["foxglove.PosesInFrame"] >= 10, checked
        topics = {c.topic for c in summary.channels.values()}
        assert f"wearnav/{USER}/perception/scan/foxglove" in topics
