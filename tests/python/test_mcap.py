"""A recording of `wearnav record` read by a tool no one here wrote: the `mcap` package
from PyPI opens the file, and every payload decodes with wearnav_schemas.

Starts the demo (built by `cargo build --workspace`) on a free loopback port, records
5 s of it with `wearnav record`, then reads the file with ``mcap.reader.make_reader``.
"""

import json
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
