#!/usr/bin/env python3
"""Send one speech intent or user command to a wearnav user's agents.

    python3 schemas/python/send.py --user alice speech "door on your left" --priority important
    python3 schemas/python/send.py --user alice cmd destination kitchen
    python3 schemas/python/send.py --user alice cmd mute off
    python3 schemas/python/send.py --user alice cmd floor 1
    python3 schemas/python/send.py --user alice cmd door 214
    python3 schemas/python/send.py --user alice cmd place "room 204"
    python3 schemas/python/send.py --user alice --dry-run cmd where-am-i

Encodes with wearnav_schemas (the same bytes a Rust agent would send), then puts it
on ``wearnav/<user>/feedback/speech`` or ``wearnav/<user>/cmd/<verb>`` with the
schema named in the Zenoh encoding and the QoS of the Rust bus (speech: real-time,
express; commands: blocking, so they are not dropped). It waits for a subscriber
(--wait) so the one put is not lost to discovery. --dry-run prints the key, the
encoding and the payload in hex instead of sending.
"""

import argparse
import json
import sys
import time

import zenoh

from wearnav_schemas import Keys, encode, encoding_schema

SENDER = "send.py"
#: Rust rejects longer utterances (wire.rs ``MAX_SPEECH_CHARS``).
MAX_SPEECH_CHARS = 1000
PRIORITIES = ["important", "message", "text", "notification", "progress"]


def parse(argv):
    """Parse the command line (``speech`` or ``cmd`` subcommand)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--user", required=True, help="whose agents to talk to")
    parser.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                        help="send through this Zenoh endpoint (an agent's or router's listener), "
                             "as its client, e.g. tcp/192.168.1.20:7447")
    parser.add_argument("--wait", type=float, default=3.0, metavar="S",
                        help="wait up to S seconds for a subscriber to appear (default 3)")
    parser.add_argument("--dry-run", action="store_true",
                        help="print key, encoding and payload hex instead of sending")
    what = parser.add_subparsers(dest="what", required=True)

    speech = what.add_parser("speech", help="say something to the user")
    speech.add_argument("text")
    speech.add_argument("--priority", choices=PRIORITIES, default="message")
    speech.add_argument("--interrupt", action="store_true", help="cut off what is being said")
    speech.add_argument("--ttl-ms", type=int, default=5000,
                        help="drop it if it cannot start within this time (default 5000)")
    speech.add_argument("--dedup-key", default="", help="not repeated within the dedup window")
    speech.add_argument("--notice", action="store_true",
                        help="announce it with a short light double tap where a device can")

    cmd = what.add_parser("cmd", help="a user command")
    verbs = cmd.add_subparsers(dest="verb", required=True)
    verbs.add_parser("destination", help="start guidance").add_argument("label")
    verbs.add_parser("where-am-i", help="say where I am")
    verbs.add_parser("mute", help="mute speech (warnings still sound)").add_argument(
        "state", nargs="?", choices=["on", "off"], default="on")
    verbs.add_parser("repeat", help="repeat the last instruction")
    verbs.add_parser("cancel", help="stop guidance")
    verbs.add_parser("floor", help="say which floor I am on (after an elevator or stairs)").add_argument(
        "floor", type=int)
    verbs.add_parser("door", help="say the number of the door I am at (read on its sign)").add_argument(
        "number")
    verbs.add_parser("place", help="say which named place of the map I am near (\"room 204\")").add_argument(
        "label")

    args = parser.parse_args(argv)
    if args.what == "speech" and not args.text.strip():
        parser.error("speech text is empty; agents reject empty utterances")
    if args.what == "speech" and len(args.text) > MAX_SPEECH_CHARS:
        parser.error(f"speech text is longer than {MAX_SPEECH_CHARS} characters")
    return args


def message(args):
    """(key, schema name, body) for the parsed command line."""
    keys = Keys(args.user)
    if args.what == "speech":
        body = {
            "text": args.text,
            "priority": args.priority.capitalize(),
            "interrupt": args.interrupt,
            "ttl_ms": args.ttl_ms,
            "dedup_key": args.dedup_key,
            "notice": args.notice,
        }
        return keys.speech(), "speech_intent", body
    commands = {
        "destination": lambda: {"Destination": {"label": args.label}},
        "where-am-i": lambda: "WhereAmI",
        "mute": lambda: {"Mute": {"muted": args.state == "on"}},
        "repeat": lambda: "Repeat",
        "cancel": lambda: "Cancel",
        "floor": lambda: {"Floor": {"floor": args.floor}},
        "door": lambda: {"Door": {"number": args.number}},
        "place": lambda: {"Place": {"label": args.label}},
    }
    return keys.cmd(args.verb), "command", commands[args.verb]()


def main(argv=None):
    args = parse(argv)
    key, name, body = message(args)
    payload = encode(name, body, sender=SENDER, seq=0, capture_ns=time.time_ns())
    encoding = zenoh.Encoding.APPLICATION_OCTET_STREAM.with_schema(encoding_schema(name))
    if args.dry_run:
        print(key, encoding, payload.hex())
        return 0

    config = zenoh.Config()
    if args.connect:
        # A client of the node it names, which routes the put to every subscriber it
        # knows. As a peer, the one put went only to peers linked directly by then: the
        # listener's own subscriptions satisfied the matching check at once, and an
        # agent that only connects to that listener (the compute agent, for commands)
        # was reached only once gossip had linked it too, about a second later: the
        # command was reported sent and never arrived (tests/browser/monitor.test.mjs).
        config.insert_json5("mode", json.dumps("client"))
        config.insert_json5("connect/endpoints", json.dumps(args.connect))
    if name == "speech_intent":
        qos = dict(priority=zenoh.Priority.REAL_TIME, congestion_control=zenoh.CongestionControl.DROP,
                   express=True)
    else:
        qos = dict(priority=zenoh.Priority.DATA, congestion_control=zenoh.CongestionControl.BLOCK)
    with zenoh.open(config) as session:
        publisher = session.declare_publisher(key, encoding=encoding, **qos)
        # Scouting takes a moment: a put before any agent is found would go nowhere.
        deadline = time.monotonic() + args.wait
        while not publisher.matching_status and time.monotonic() < deadline:
            time.sleep(0.05)
        if not publisher.matching_status:
            print(f"send: nobody subscribes to {key} (waited {args.wait} s); is an agent "
                  f"running for user {args.user!r}? (on another host, try --connect "
                  f"tcp/HOST:7447)", file=sys.stderr)
            return 1
        publisher.put(payload)
    print(f"sent {name} on {key} ({len(payload)} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
