#!/usr/bin/env python3
"""Watch everything one wearnav user's agents say, live.

    python3 schemas/python/monitor.py --user alice
    python3 schemas/python/monitor.py --user alice --connect tcp/192.168.1.20:7447 --count 50 --json

Opens a Zenoh session (peer mode, multicast scouting: agents on the LAN are found
with no configuration; --connect adds an endpoint), subscribes ``wearnav/<user>/**``
and the agents' liveliness tokens ``wearnav/<user>/health/*``, and prints one line per
message: key, type, sequence number, age since capture and a short summary (or one
JSON object per line with --json). Payloads that do not decode are shown with the
error kind, and watching goes on.
"""

import argparse
import json
import sys
import threading
import time

import zenoh

from wearnav_schemas import Keys, WireError, decode, schema_of_encoding, summarise


def describe(key, encoding, payload, now_ns, as_json):
    """One output line for one sample (pure: the tests call it without a bus)."""
    try:
        message = decode(payload, expected=schema_of_encoding(encoding))
    except WireError as err:
        if as_json:
            return json.dumps({"key": key, "error": err.kind, "detail": str(err), "bytes": len(payload)})
        return f"{key}  REJECTED {err.kind}: {err} ({len(payload)} bytes)"
    age_ms = (now_ns - message.header["capture_ns"]) / 1e6
    if as_json:
        line = {"key": key, "age_ms": round(age_ms, 3), **message.to_json(summarise_bytes=True)}
        return json.dumps(line, ensure_ascii=False)
    seq = message.header["seq"]
    return f"{key}  {message.schema} #{seq}  {age_ms:.1f} ms  {summarise(message)}"


def describe_liveliness(key, alive, as_json):
    """One output line for an agent's liveliness token appearing or going away."""
    if as_json:
        return json.dumps({"key": key, "liveliness": "alive" if alive else "gone"})
    return f"{key}  {'ALIVE' if alive else 'GONE'}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--user", required=True, help="whose bus to watch (wearnav/<user>/**)")
    parser.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                        help="also connect to this Zenoh endpoint, e.g. tcp/192.168.1.20:7447")
    parser.add_argument("--count", type=int, help="exit 0 after this many messages")
    parser.add_argument("--timeout", type=float, metavar="S",
                        help="give up after S seconds: exit 1 if --count messages (or, "
                             "without --count, any message) did not arrive")
    parser.add_argument("--json", action="store_true", help="one JSON object per line")
    args = parser.parse_args()

    keys = Keys(args.user)
    config = zenoh.Config()
    if args.connect:
        config.insert_json5("connect/endpoints", json.dumps(args.connect))

    lock = threading.Lock()
    received = [0]
    done = threading.Event()

    def on_sample(sample):
        if sample.kind != zenoh.SampleKind.PUT:
            return
        line = describe(str(sample.key_expr), str(sample.encoding), sample.payload.to_bytes(),
                        time.time_ns(), args.json)
        with lock:
            if done.is_set():
                return
            print(line, flush=True)
            received[0] += 1
            if args.count is not None and received[0] >= args.count:
                done.set()

    def on_liveliness(sample):
        alive = sample.kind == zenoh.SampleKind.PUT
        line = describe_liveliness(str(sample.key_expr), alive, args.json)
        with lock:
            if not done.is_set():
                print(line, flush=True)

    with zenoh.open(config) as session:
        session.declare_subscriber(keys.all(), on_sample)
        session.liveliness().declare_subscriber(keys.health_any(), on_liveliness, history=True)
        try:
            finished = done.wait(args.timeout)
        except KeyboardInterrupt:
            return 0
        done.set()
        if finished or (args.count is None and received[0] > 0):
            return 0
        wanted = args.count if args.count is not None else 1
        print(f"monitor: {received[0]} of {wanted} messages on {keys.all()} within "
              f"{args.timeout} s; is an agent running for user {args.user!r}? "
              f"(on another host, try --connect tcp/HOST:7447)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
