#!/usr/bin/env python3
"""The Python monitor of tests/netns.rs: an eclipse-zenoh client in a network namespace
of its own that reports, one JSON object per line on stdout, every message it is sent on
the keys it is given and every agent's liveliness token appearing or going.

    monitor.py --config client.json5 --user U [--connect tcp/10.0.0.2:7447]
               --key perception/hazard --key feedback/applied [--key sensor/*/depth]

Each line has the key, the receive time (``rx``, ns, this host's wall clock, and
``mono``, its monotonic clock, which no clock step moves) and the
envelope (sender, session, seq, capture stamp ``cap``, payload bytes ``n``); depth
frames are read no further than their envelope (what matters is that they arrive and
when), hazards add the frame's stage latencies, ``feedback/applied`` what was done and
when, health its streams. ``{"ready": true}`` comes once the subscriptions are declared.
It runs until its standard input closes (the test holds it open) or SIGTERM. A session
that cannot be opened (the router refused the link) prints ``{"connected": false}`` and
exits with status 2.
"""

import argparse
import json
import math
import signal
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "schemas" / "python"))

import zenoh  # noqa: E402

from wearnav_schemas import WireError, decode, decode_header, schema_of_encoding  # noqa: E402

LOCK = threading.Lock()
#: Set on SIGTERM, when standard input closes, or when nobody reads standard output.
STOP = threading.Event()


def emit(obj):
    line = json.dumps(obj, separators=(",", ":"), allow_nan=False)
    with LOCK:
        if STOP.is_set():
            return
        try:
            sys.stdout.write(line + "\n")
            sys.stdout.flush()
        except OSError:
            STOP.set()


def finite(x):
    """``x``, or ``None`` for NaN and infinities (which JSON does not have)."""
    return x if math.isfinite(x) else None


def fields(schema, body):
    """What the test reads of a body, by schema."""
    if schema == "hazard":
        stages = {s["stage"]: s["us"] for s in body["latency"]}
        return {"frame_seq": body["frame_seq"], "stages_us": sum(stages.values()),
                "arrival_us": stages.get("arrival", 0), "rumble": str(body["rumble"])}
    if schema == "applied":
        action = body["action"]
        name = action if isinstance(action, str) else next(iter(action))
        out = {"device": body["device"], "action": name, "applied_ns": body["applied_ns"],
               "cause_ns": body["cause_capture_ns"]}
        if name == "OfflineWarning":
            out["offline"] = action[name]["offline"]
            out["reason"] = action[name]["reason"]
        return out
    if schema == "health_stats":
        return {"agent": body["agent"], "ok": body["ok"],
                "streams": [[s["key"], s["inbound"], s["count"], finite(s["latency_p50_ms"]),
                             finite(s["latency_p99_ms"])] for s in body["streams"]],
                "rejects": {r["kind"]: r["count"] for r in body["rejects"]}}
    return {}


def on_sample(sample):
    rx = time.time_ns()
    mono = time.monotonic_ns()
    if sample.kind != zenoh.SampleKind.PUT:
        return
    key = str(sample.key_expr)
    payload = sample.payload.to_bytes()
    schema = schema_of_encoding(sample.encoding)
    line = {"key": key, "rx": rx, "mono": mono, "n": len(payload), "schema": schema}
    try:
        if schema == "depth_frame":
            header, _ = decode_header(payload)
            body = None
        else:
            message = decode(payload, expected=schema)
            header, body = message.header, message.body
    except WireError as err:
        line["error"] = err.kind
        emit(line)
        return
    line.update(sender=header["sender"], session=header["session"], seq=header["seq"], cap=header["capture_ns"])
    if body is not None:
        line.update(fields(schema, body))
    emit(line)


def on_liveliness(sample):
    emit({"live": str(sample.key_expr), "alive": sample.kind == zenoh.SampleKind.PUT, "rx": time.time_ns()})


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", required=True, help="Zenoh JSON5 configuration (a client of the router)")
    parser.add_argument("--user", required=True)
    parser.add_argument("--connect", help="the router's endpoint, replacing the configuration's")
    parser.add_argument("--key", action="append", default=[], help="key under wearnav/<user>/ (repeatable)")
    args = parser.parse_args()

    config = zenoh.Config.from_file(args.config)
    if args.connect:
        config.insert_json5("connect/endpoints", json.dumps([args.connect]))
    signal.signal(signal.SIGTERM, lambda *_: STOP.set())
    try:
        session = zenoh.open(config)
    except Exception as err:  # noqa: BLE001 (zenoh raises its own ZError)
        # a refused link (no certificate, another authority) is a result, not a crash
        emit({"connected": False, "error": str(err), "rx": time.time_ns()})
        return 2
    with session:
        subscribers = [session.declare_subscriber(f"wearnav/{args.user}/{k}", on_sample) for k in args.key]
        watcher = session.liveliness().declare_subscriber(f"wearnav/{args.user}/health/*", on_liveliness,
                                                          history=True)
        emit({"ready": True, "keys": args.key, "rx": time.time_ns()})
        reader = threading.Thread(target=lambda: (sys.stdin.read(), STOP.set()), daemon=True)
        reader.start()
        STOP.wait()
        del subscribers, watcher
    return 0


if __name__ == "__main__":
    sys.exit(main())
