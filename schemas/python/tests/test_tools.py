"""send.py builds payloads this package decodes; monitor.py describes samples
(decoded, rejected, liveliness) in one line. No bus needed."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("zenoh", reason="monitor.py and send.py need eclipse-zenoh")

import monitor  # noqa: E402
import send  # noqa: E402
from wearnav_schemas import decode, encode, encoding_schema  # noqa: E402

SCRIPTS = Path(__file__).resolve().parents[1]
NOW_NS = 1_763_776_800_000_000_000


def dry_run(*argv):
    """Run send.py --dry-run as a user would; return (key, encoding, payload)."""
    out = subprocess.run(
        [sys.executable, str(SCRIPTS / "send.py"), "--user", "alice", "--dry-run", *argv],
        check=True, capture_output=True, text=True,
    ).stdout.split()
    return out[0], out[1], bytes.fromhex(out[2])


def test_speech_from_the_command_line_decodes_as_that_speech_intent():
    key, encoding, payload = dry_run("speech", "Tür links", "--priority", "important",
                                     "--interrupt", "--ttl-ms", "1500")
    assert key == "wearnav/alice/feedback/speech"
    assert encoding == "application/octet-stream;" + encoding_schema("speech_intent")
    message = decode(payload, expected="speech_intent")
    assert message.body == {"text": "Tür links", "priority": "Important", "interrupt": True,
                            "ttl_ms": 1500, "dedup_key": "", "notice": False}
    assert message.header["sender"] == "send.py"


@pytest.mark.parametrize(
    "argv, key, body",
    [
        (["destination", "kitchen"], "wearnav/alice/cmd/destination",
         {"Destination": {"label": "kitchen"}}),
        (["where-am-i"], "wearnav/alice/cmd/where-am-i", "WhereAmI"),
        (["mute"], "wearnav/alice/cmd/mute", {"Mute": {"muted": True}}),
        (["mute", "off"], "wearnav/alice/cmd/mute", {"Mute": {"muted": False}}),
        (["repeat"], "wearnav/alice/cmd/repeat", "Repeat"),
        (["floor", "-1"], "wearnav/alice/cmd/floor", {"Floor": {"floor": -1}}),
        (["door", "B1.07"], "wearnav/alice/cmd/door", {"Door": {"number": "B1.07"}}),
        (["place", "room 204"], "wearnav/alice/cmd/place", {"Place": {"label": "room 204"}}),
    ],
)
def test_command_goes_on_its_verb_key_and_decodes(argv, key, body):
    got_key, _, payload = dry_run("cmd", *argv)
    assert got_key == key
    assert decode(payload, expected="command").body == body


def test_empty_speech_is_refused_before_sending():
    with pytest.raises(SystemExit):
        send.parse(["--user", "alice", "speech", "   "])


def test_monitor_line_has_key_type_seq_age_and_hazard_summary():
    hazard = {
        "frame_seq": 7, "ficf": {"left": 0.0, "forward": 2.0, "right": 0.0},
        "cacf": {"left": 0.0, "forward": 0.0, "right": 0.0}, "active": "Ficf",
        "rumble": "Both", "ground": "Found", "plane_camera": [0.0, -1.0, 0.0, 1.2],
        "nearest_m": 0.75, "nearest_bearing_deg": 5.0, "ttc_s": None,
        "dropoff_ahead": False, "turn_ahead": False, "body_turn_deg_s": None, "predictive": False, "gravity": True,
        "latency": [],
    }
    payload = encode("hazard", hazard, sender="compute", seq=42, capture_ns=NOW_NS - 3_500_000)
    line = monitor.describe("wearnav/alice/perception/hazard",
                            "application/octet-stream;wearnav/hazard/v5", payload, NOW_NS, False)
    assert line == ("wearnav/alice/perception/hazard  hazard #42  3.5 ms  "
                    "rumble Both nearest 0.75 m at 5 deg ground Found")


def test_monitor_json_line_summarises_depth_bytes_by_length():
    frame = {
        "width": 2, "height": 1, "depth_scale_m": 0.001,
        "intrinsics": {"fx": 1.0, "fy": 1.0, "cx": 0.5, "cy": 0.5},
        "gravity_camera": None, "mount": None, "encoding": "Raw", "data": b"\x01\x00\x02\x00",
    }
    payload = encode("depth_frame", frame, sender="sensor", seq=3, capture_ns=NOW_NS - 1_000_000)
    line = json.loads(monitor.describe("wearnav/alice/sensor/cane/depth", "", payload, NOW_NS, True))
    assert line["schema"] == "depth_frame" and line["header"]["seq"] == 3
    assert line["age_ms"] == 1.0
    assert line["body"]["data"] == {"bytes": 4}


def test_monitor_shows_undecodable_payload_with_its_error_kind():
    line = monitor.describe("wearnav/alice/perception/hazard",
                            "application/octet-stream;wearnav/hazard/v5", b"\x06\x00", NOW_NS, False)
    assert line.startswith("wearnav/alice/perception/hazard  REJECTED truncated")
    as_json = json.loads(monitor.describe("k", "", b"\x06\x00\x05\x00", NOW_NS, True))
    assert as_json["error"] == "corrupt" and as_json["bytes"] == 4


def test_monitor_rejects_a_payload_whose_encoding_names_another_schema():
    payload = encode("command", "Repeat", sender="t", seq=0, capture_ns=NOW_NS)
    line = monitor.describe("k", "application/octet-stream;wearnav/hazard/v5", payload, NOW_NS, False)
    assert "REJECTED wrong_schema" in line


def test_monitor_liveliness_lines():
    assert monitor.describe_liveliness("wearnav/alice/health/compute-agent", False, False) == \
        "wearnav/alice/health/compute-agent  GONE"
    assert json.loads(monitor.describe_liveliness("k", True, True)) == {"key": "k", "liveliness": "alive"}
