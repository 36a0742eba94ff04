"""The Python monitor against a running `wearnav demo`: real processes, real Zenoh.

Starts the demo (built by `cargo build --workspace`) listening on a free loopback
port, runs `monitor.py --connect ... --count N --json`, and checks that every message
decoded, that the expected types are there, and that sequence numbers of each
publisher are continuous (no message lost between the agents and the monitor).
"""

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
WEARNAV = ROOT / "target" / "debug" / "wearnav"
MONITOR = ROOT / "schemas" / "python" / "monitor.py"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def demo():
    if not WEARNAV.exists():
        pytest.fail(f"{WEARNAV} missing: run `cargo build --workspace` first")
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    proc = subprocess.Popen(
        [str(WEARNAV), "demo", "--duration", "25s", "--user", "pytest", "--listen", endpoint],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        env={**os.environ, "RUST_LOG": "warn"},
        text=True,
    )
    yield endpoint
    proc.terminate()
    try:
        _, err = proc.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    assert proc.returncode == 0, f"demo exited {proc.returncode} after SIGTERM:\n{err[-3000:]}"


def test_monitor_decodes_a_running_demo_with_continuous_sequences(demo):
    count = 400
    run = subprocess.run(
        [sys.executable, str(MONITOR), "--user", "pytest", "--connect", demo,
         "--count", str(count), "--json", "--timeout", "20"],
        capture_output=True, text=True, timeout=60,
    )
    assert run.returncode == 0, run.stderr
    lines = [json.loads(l) for l in run.stdout.splitlines() if l.strip()]
    messages = [l for l in lines if "schema" in l]
    errors = [l for l in lines if "error" in l]
    assert not errors, f"undecodable payloads: {errors[:3]}"
    assert len(messages) >= count * 0.9

    types = {m["schema"] for m in messages}
    for expected in ("depth_frame", "hazard", "scan", "haptic_intent"):
        assert expected in types, f"no {expected} among {sorted(types)}"

    # Per (key, sender), sequence numbers rise by exactly one: nothing was lost.
    last = {}
    for m in messages:
        stream = (m["key"], m["header"]["sender"])
        seq = m["header"]["seq"]
        if stream in last:
            assert seq == last[stream] + 1, f"{stream}: seq {last[stream]} then {seq}"
        last[stream] = seq

    # Ages come from the capture stamps and must be sane on one machine.
    hazards = [m for m in messages if m["schema"] == "hazard"]
    assert all(-5 < m["age_ms"] < 1000 for m in hazards), [m["age_ms"] for m in hazards][:10]

    # The simulator wears an IMU on the body and the compute agent reads it: hazards
    # carry the body's turn rate it used. The approach world's walker walks to a wall
    # and backs up without turning: only the torso's sway (under 17 deg/s) is read.
    rates = [m["body"]["body_turn_deg_s"] for m in hazards]
    known = [r for r in rates if r is not None]
    assert len(known) >= 0.8 * len(rates), f"{len(known)} of {len(rates)} hazards with a body turn rate"
    assert all(abs(r) < 20.0 for r in known), max(known, key=abs)
    assert any(abs(r) > 3.0 for r in known), "no sway read at all"
    assert not any(m["body"]["turn_ahead"] for m in hazards)
