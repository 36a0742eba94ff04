#!/usr/bin/env python3
"""Publish haptic intents at a steady rate, for the phone latency benchmark.

    python3 tests/browser/publish_intents.py --user U --connect tcp/127.0.0.1:7447 \
        --count 1000 --hz 30 > captures.jsonl

Intents alternate between the left and the right side (steady, full strength), so
each one changes what the phone plays and the feedback agent sends the page a new
pattern. A clear hazard goes out with each, as the compute agent's would: without
hazards the feedback agent warns that detection is offline, and that warning, not the
intents, would drive the phone. Each intent's capture stamp (``time.time_ns()``, the
clock the page's ``performance.timeOrigin + performance.now()`` reads on this machine)
is printed as a JSON line ``{"k": k, "side": "left"|"right", "capture_ns": ...}``.
Waits (up to --wait seconds) for the feedback agent to subscribe first.
"""

import argparse
import json
import pathlib
import sys
import time

import zenoh

from wearnav_schemas import Keys, encode, encoding_schema

SENDER = "phone-latency"
VECTORS = pathlib.Path(__file__).resolve().parents[2] / "schemas" / "vectors"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--user", required=True)
    parser.add_argument("--connect", required=True, metavar="ENDPOINT")
    parser.add_argument("--count", type=int, default=1000, help="intents to publish (default 1000)")
    parser.add_argument("--hz", type=float, default=30.0, help="intents a second (default 30)")
    parser.add_argument("--wait", type=float, default=10.0, metavar="S",
                        help="wait up to S seconds for a subscriber (default 10)")
    args = parser.parse_args(argv)

    keys = Keys(args.user)
    hazard = json.loads((VECTORS / "hazard_clear.json").read_text())["body"]
    hazard["nearest_m"] = float("inf")  # nothing ahead (JSON has no infinity: null there)
    config = zenoh.Config()
    config.insert_json5("connect/endpoints", json.dumps([args.connect]))
    config.insert_json5("scouting/multicast/enabled", "false")
    realtime = dict(priority=zenoh.Priority.REAL_TIME, congestion_control=zenoh.CongestionControl.DROP,
                    express=True)
    with zenoh.open(config) as session:
        def publisher(key, name, **qos):
            encoding = zenoh.Encoding.APPLICATION_OCTET_STREAM.with_schema(encoding_schema(name))
            return session.declare_publisher(key, encoding=encoding, **qos)

        haptic = publisher(keys.haptic(), "haptic_intent", **realtime)
        hazards = publisher(keys.hazard(), "hazard", priority=zenoh.Priority.INTERACTIVE_HIGH,
                            congestion_control=zenoh.CongestionControl.DROP)
        deadline = time.monotonic() + args.wait
        while not (haptic.matching_status.matching and hazards.matching_status.matching):
            if time.monotonic() > deadline:
                print(f"publish_intents: nobody subscribes to {keys.haptic()} after {args.wait} s",
                      file=sys.stderr)
                return 1
            time.sleep(0.05)

        period = 1.0 / args.hz
        next_at = time.monotonic()
        for k in range(args.count):
            next_at += period
            capture_ns = time.time_ns()
            hazards.put(encode("hazard", dict(hazard, frame_seq=k), sender=SENDER, seq=k,
                               capture_ns=capture_ns))
            side = "left" if k % 2 == 0 else "right"
            body = {"left": 1.0 if side == "left" else 0.0, "right": 1.0 if side == "right" else 0.0,
                    "pattern": "Steady", "ttl_ms": 500}
            haptic.put(encode("haptic_intent", body, sender=SENDER, seq=k, capture_ns=capture_ns))
            print(json.dumps({"k": k, "side": side, "capture_ns": capture_ns}), flush=True)
            time.sleep(max(0.0, next_at - time.monotonic()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
