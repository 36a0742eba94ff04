"""Guidance from Python against a running `wearnav demo --source sim:building`: real
processes, real Zenoh. `send.py cmd destination` starts guidance (what the user hears
comes back on ``feedback/speech``, the route on ``route/state``), and the destinations
and a route preview are asked for with Zenoh queries and decoded with wearnav_schemas;
`send.py cmd door` gives the localization a door number.
"""

import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import zenoh

ROOT = Path(__file__).resolve().parents[2]
WEARNAV = ROOT / "target" / "debug" / "wearnav"
SEND = ROOT / "schemas" / "python" / "send.py"
sys.path.insert(0, str(ROOT / "schemas" / "python"))

from wearnav_schemas import Keys, WireError, decode  # noqa: E402

USER = "pyguide"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def demo():
    if not WEARNAV.exists():
        pytest.fail(f"{WEARNAV} missing: run `cargo build --workspace` first")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen(
        [str(WEARNAV), "demo", "--source", "sim:building", "--duration", "40s", "--user", USER,
         "--listen", endpoint],
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


def session(endpoint):
    config = zenoh.Config()
    config.insert_json5("connect/endpoints", f'["{endpoint}"]')
    config.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(config)


def ask(s, selector, timeout=5.0):
    """The first reply to a query: ("ok", header, body) or ("err", text)."""
    for reply in s.get(selector, timeout=timeout):
        if reply.ok is not None:
            m = decode(reply.ok.payload.to_bytes())
            return "ok", m.header, m.body
        return "err", reply.err.payload.to_bytes().decode()
    return None


def test_send_py_starts_guidance_and_queries_answer(demo):
    keys = Keys(USER)
    heard, routes, poses = [], [], []
    lock = threading.Lock()

    def keep(into):
        def on_sample(sample):
            try:
                body = decode(sample.payload.to_bytes()).body
            except WireError as e:  # a test that can fail: nothing may be undecodable
                body = {"undecodable": str(e)}
            with lock:
                into.append(body)
        return on_sample

    with session(demo) as s:
        subs = [
            s.declare_subscriber(keys.speech(), keep(heard)),
            s.declare_subscriber(keys.route_state(), keep(routes)),
            s.declare_subscriber(keys.pose(), keep(poses)),
        ]
        # the compute agent localizes first: the route preview needs the position
        deadline = time.time() + 30
        while time.time() < deadline:
            with lock:
                if any(p.get("status") == "Tracking" for p in poses):
                    break
            time.sleep(0.2)
        with lock:
            assert any(p.get("status") == "Tracking" for p in poses), poses[-3:]

        kind, header, body = ask(s, keys.query("destinations"))
        assert kind == "ok" and header["sender"] == "compute-agent"
        places = {(d["label"], d["at"]["floor"]) for d in body["destinations"]}
        assert {("entrance", 0), ("room 204", 1)} <= places, places

        kind, _, preview = ask(s, keys.query("route") + "?to=room%20204")
        assert kind == "ok" and preview["status"] == "Preview", preview
        assert preview["route"][-1]["floor"] == 1 and 10 < preview["distance_left_m"] < 40
        assert ask(s, keys.query("route") + "?to=kitchen")[1].startswith(
            "I do not know a place called kitchen")

        run = subprocess.run(
            [sys.executable, str(SEND), "--user", USER, "--connect", demo,
             "cmd", "destination", "room 204"],
            capture_output=True, text=True, timeout=30,
        )
        assert run.returncode == 0, run.stderr
        deadline = time.time() + 10
        while time.time() < deadline:
            with lock:
                if any(h.get("text", "").startswith("Route to room 204:") for h in heard):
                    break
            time.sleep(0.2)
        with lock:
            said = [h.get("text") for h in heard]
            started = [h for h in heard if h.get("text", "").startswith("Route to room 204:")]
            guiding = [r for r in routes if r.get("status") == "Guiding"]
        assert started and started[0]["priority"] == "Message", said
        assert guiding and guiding[-1]["destination"] == "room 204", routes[-3:]

        # the user at a door says its number (a landmark for localization): the agent
        # acknowledges one its map has and refuses one it has not, saying so
        for number in ["101", "999"]:
            run = subprocess.run(
                [sys.executable, str(SEND), "--user", USER, "--connect", demo, "cmd", "door", number],
                capture_output=True, text=True, timeout=30,
            )
            assert run.returncode == 0, run.stderr
        wanted = ["Door 101.", "Door 999 is not on my map."]
        deadline = time.time() + 10
        while time.time() < deadline:
            with lock:
                if all(any(h.get("text") == w for h in heard) for w in wanted):
                    break
            time.sleep(0.2)
        with lock:
            said = [h.get("text") for h in heard]
        assert all(w in said for w in wanted), said
        assert not any("undecodable" in m for m in heard + routes + poses)
        for sub in subs:
            sub.undeclare()
