"""One short human line per decoded message, for ``monitor.py`` and logs."""

import math


def _m(value):
    return "none" if not math.isfinite(value) else f"{value:.2f} m"


def _pattern(pattern):
    if pattern == "Steady":
        return "steady"
    pulses = pattern["Pulses"]
    return f"pulses {pulses['period_ms']} ms duty {pulses['duty']:.2f}"


def _variant(value):
    """Split an enum value into (variant name, fields dict)."""
    if isinstance(value, str):
        return value, {}
    ((name, fields),) = value.items()
    return name, fields


def _depth_frame(b):
    encoding, fields = _variant(b["encoding"])
    step = f" step {fields['step']}" if "step" in fields else ""
    return f"{b['width']}x{b['height']} {encoding}{step} {len(b['data'])} B"


def _imu_batch(b):
    return f"{len(b['samples'])} samples"


def _odom_increment(b):
    ms = (b["to_ns"] - b["from_ns"]) / 1e6
    yaw = math.degrees(b["yaw_rad"])
    return f"fwd {b['forward_m']:.3f} m left {b['left_m']:.3f} m yaw {yaw:.1f} deg in {ms:.0f} ms"


def _ground_truth(b):
    yaw = math.degrees(b["yaw_rad"])
    return f"x {b['x_m']:.2f} y {b['y_m']:.2f} yaw {yaw:.0f} deg floor {b['floor']}"


def _scan(b):
    ranges = b["ranges_m"]
    seen = [(r, i) for i, r in enumerate(ranges) if math.isfinite(r)]
    if not seen:
        return f"{len(ranges)} bins, nothing within {b['range_max_m']:.1f} m"
    r, i = min(seen)
    bearing = b["angle_min_deg"] + i * b["angle_increment_deg"]
    return f"{len(ranges)} bins, nearest {_m(r)} at {bearing:.0f} deg"


def _hazard(b):
    line = f"rumble {b['rumble']} nearest {_m(b['nearest_m'])}"
    if math.isfinite(b["nearest_m"]):
        line += f" at {b['nearest_bearing_deg']:.0f} deg"
    line += f" ground {b['ground']}"
    if b["ttc_s"] is not None:
        line += f" ttc {b['ttc_s']:.1f} s"
    if b["dropoff_ahead"]:
        line += " DROP-OFF AHEAD"
    if b["turn_ahead"]:
        line += " (what the body turns into)"
    if b["body_turn_deg_s"] is not None:
        line += f" body turning {b['body_turn_deg_s']:+.0f} deg/s"
    return line


def _pose(b):
    yaw = math.degrees(b["yaw_rad"])
    status, _ = _variant(b["status"])
    if b["guides"] and status != "Tracking":
        status += " (followed: guidance takes it)"
    return f"{status} x {b['x_m']:.2f} y {b['y_m']:.2f} yaw {yaw:.0f} deg floor {b['floor']}"


def _route_state(b):
    status, _ = _variant(b["status"])
    if not b["destination"]:
        return f"{status}: no route"
    return (
        f"{status} to {b['destination']!r} (floor {b['floor']}): {_m(b['distance_left_m'])} "
        f"left, {len(b['route'])} points, {b['instruction']!r}"
    )


def _destinations(b):
    names = ", ".join(f"{d['label']!r} (floor {d['at']['floor']})" for d in b["destinations"])
    return f"{len(b['destinations'])} destinations: {names}"


def _haptic_intent(b):
    return (
        f"left {b['left']:.2f} right {b['right']:.2f} {_pattern(b['pattern'])} "
        f"ttl {b['ttl_ms']} ms"
    )


def _speech_intent(b):
    interrupt = " interrupt" if b["interrupt"] else ""
    return f"{b['priority']}{interrupt} {b['text']!r}"


def _applied(b):
    action, fields = _variant(b["action"])
    if action == "Rumble":
        detail = f"left {fields['left']:.2f} right {fields['right']:.2f} {_pattern(fields['pattern'])}"
    elif action == "OfflineWarning":
        detail = ("OFFLINE " if fields["offline"] else "back online ") + repr(fields["reason"])
    elif action == "SpeechStarted":
        detail = f"{fields['priority']} {fields['text']!r}"
    elif action == "SpeechDropped":
        detail = f"{fields['text']!r} ({fields['reason']})"
    else:
        detail = " ".join(repr(v) for v in fields.values())
    return f"{b['device']}: {action} {detail}"


def _command(b):
    verb, fields = _variant(b)
    if verb == "Destination":
        return f"Destination {fields['label']!r}"
    if verb == "Mute":
        return "Mute on" if fields["muted"] else "Mute off"
    if verb == "Floor":
        return f"Floor {fields['floor']}"
    return verb


def _phone_haptic(b):
    return f"#{b['id']} vibrate {b['pattern_ms']} (left {b['left']:.2f} right {b['right']:.2f})"


def _phone_speech(b):
    verb, fields = _variant(b)
    if verb == "Say":
        return f"#{fields['id']} say {fields['priority']} {fields['text']!r}"
    return f"#{fields['id']} cut"


def _phone_ack(b):
    event, fields = _variant(b["event"])
    reason = f" ({fields['reason']})" if fields else ""
    return f"#{b['id']} {event}{reason}"


def _phone_motion(b):
    heading = "no heading" if b["heading_deg"] is None else f"heading {b['heading_deg']:.0f} deg"
    return f"{heading}, {b['steps']} steps"


def _camera_place(b):
    status, _ = _variant(b["status"])
    yaw = math.degrees(b["yaw_rad"])
    return f"camera at x {b['x_m']:.2f} y {b['y_m']:.2f} looking {yaw:.0f} deg floor {b['floor']} ({status})"


def _pressure(b):
    return f"{b['pressure_pa']:.1f} Pa"


def _health_stats(b):
    state = "ok" if b["ok"] else "NOT OK"
    rejects = sum(r["count"] for r in b["rejects"])
    missed = sum(s["missed"] for s in b["streams"])
    return (
        f"{b['agent']} {state} up {b['uptime_ms'] / 1000:.0f} s, {len(b['streams'])} streams, "
        f"{rejects} rejects, {missed} lost on the way: {b['status']}"
    )


SUMMARIES = {
    "depth_frame": _depth_frame,
    "imu_batch": _imu_batch,
    "odom_increment": _odom_increment,
    "ground_truth": _ground_truth,
    "scan": _scan,
    "hazard": _hazard,
    "pose": _pose,
    "route_state": _route_state,
    "haptic_intent": _haptic_intent,
    "speech_intent": _speech_intent,
    "applied": _applied,
    "command": _command,
    "health_stats": _health_stats,
    "destinations": _destinations,
    "phone_haptic": _phone_haptic,
    "phone_speech": _phone_speech,
    "phone_ack": _phone_ack,
    "phone_motion": _phone_motion,
    "pressure": _pressure,
    "camera_place": _camera_place,
}


def summarise(message):
    """A short line saying what a decoded :class:`~wearnav_schemas.wire.Message` carries
    (hazard: rumble, nearest obstacle, ground; applied: device and action; ...)."""
    return SUMMARIES[message.schema](message.body)
