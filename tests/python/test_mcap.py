"""A recording of `wearnav record` read by a tool no one here wrote: the `mcap` package
from PyPI opens the file, and every payload decodes with wearnav_schemas.

Starts the demo (built by `cargo build --workspace`) on a free loopback port, records
5 s of it with `wearnav record`, then reads the file with ``mcap.reader.make_reader``.
"""

import base64
import json
import math
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
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


def wait_listening(port, demo, log, limit=20.0):
    """Until the demo listens on `port`; fails with the demo's log if it exits first or
    does not listen within `limit` seconds."""
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        if demo.poll() is not None:
            pytest.fail(f"the demo exited ({demo.returncode}) before listening on port {port}; "
                        f"its log:\n{log.read_text()[-3000:]}")
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.1)
    pytest.fail(f"nothing listens on port {port} after {limit} s; the demo's log:\n{log.read_text()[-3000:]}")


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """5 s of the demo recorded once for every test of this file (each only reads it)."""
    tmp_path = tmp_path_factory.mktemp("recording")
    if not WEARNAV.exists():
        pytest.fail(f"{WEARNAV} missing: run `cargo build --workspace` first")
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    env = {**os.environ, "RUST_LOG": "warn"}
    log = tmp_path / "demo.log"
    with open(log, "wb") as sink:
        demo = subprocess.Popen(
            [str(WEARNAV), "demo", "--duration", "12s", "--user", USER, "--listen", endpoint],
            stdout=sink, stderr=subprocess.STDOUT, env=env,
        )
    try:
        wait_listening(port, demo, log)
        out = tmp_path / "walk.mcap"
        run = subprocess.run(
            [str(WEARNAV), "record", "--user", USER, "--connect", endpoint, "--no-multicast",
             "--duration", "5s", "--out", str(out), "--map", str(ROOT / "maps" / "building")],
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
              ' PosesInFrame: j.PosesInFrame, PointCloud: j.PointCloud, Grid: j.Grid,'
              ' FrameTransform: j.FrameTransform}));')
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
            if schema.name in ("foxglove.PointCloud", "foxglove.Grid", "foxglove.FrameTransform"):  # the next tests
                continue
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


def foxglove_messages(recording, name):
    """(Foxglove message, the wire message it twins or None, topic) of every `name` twin,
    each validated against Foxglove's JSON schema for it."""
    import jsonschema

    official = foxglove_json_schemas()[name.split(".")[1]]
    found = []
    with open(recording, "rb") as f:
        wire = {}
        for schema, channel, message in make_reader(f).iter_messages():
            if channel.message_encoding == "wearnav-bincode":
                wire[channel.topic] = decode(message.data)
            elif schema is not None and schema.name == name:
                assert (schema.encoding, json.loads(schema.data)["title"]) == ("jsonschema", name)
                fox = json.loads(message.data)
                jsonschema.validate(fox, official)
                found.append((fox, wire.get(channel.topic[: -len("/foxglove")]), channel.topic))
    return found


def test_every_fifteenth_depth_frame_is_a_foxglove_point_cloud_on_the_pixel_grid_it_came_from(recording):
    clouds = foxglove_messages(recording, "foxglove.PointCloud")
    assert 7 <= len(clouds) <= 14, f"{len(clouds)} clouds in 5 s of 30 Hz depth, one in 15 expected"
    for fox, depth, topic in clouds:
        assert topic.endswith("/depth/foxglove"), topic
        header, frame = depth.header, depth.body
        assert header["seq"] % 15 == 0
        assert (fox["timestamp"]["sec"], fox["timestamp"]["nsec"]) == divmod(header["capture_ns"], 10**9)
        assert fox["frame_id"] == "wearnav_camera" and fox["point_stride"] == 12
        assert [(f["name"], f["offset"], f["type"]) for f in fox["fields"]] == [("x", 0, 7), ("y", 4, 7), ("z", 8, 7)]
        xyz = np.frombuffer(base64.b64decode(fox["data"]), dtype="<f4").reshape(-1, 3)
        width, height = frame["width"], frame["height"]
        assert len(xyz) > 0.5 * (width // 4) * (height // 4), f"{len(xyz)} points of a {width}x{height} frame"
        assert len(xyz) <= -(-width // 4) * -(-height // 4)
        assert (xyz[:, 2] > 0).all() and (xyz[:, 2] < 20).all()
        # projected back with the frame's intrinsics, every point lands on a pixel of the
        # 4-pixel grid it was taken from
        k = frame["intrinsics"]
        u = xyz[:, 0] * k["fx"] / xyz[:, 2] + k["cx"]
        v = xyz[:, 1] * k["fy"] / xyz[:, 2] + k["cy"]
        for c, size in ((u, width), (v, height)):
            assert np.abs(c - 4 * np.round(c / 4)).max() < 1e-2
            assert c.min() > -0.01 and c.max() < size


def rotate(q, v):
    """The vectors `v` (n x 3) turned by the unit quaternion `q` (x, y, z, w)."""
    u, w = np.array(q[:3]), q[3]
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def test_each_hazards_floor_places_the_camera_in_the_scans_frame_and_its_point_cloud_on_that_floor(recording):
    every = foxglove_messages(recording, "foxglove.FrameTransform")
    assert {topic for _, _, topic in every} == {
        f"wearnav/{USER}/perception/hazard/foxglove", f"wearnav/{USER}/localization/camera/foxglove"}
    transforms = [t for t in every if t[2] == f"wearnav/{USER}/perception/hazard/foxglove"]
    hazards = [h for _, h, _ in transforms]
    assert len(transforms) >= 90, f"{len(transforms)} transforms in 5 s of 30 Hz hazards"
    by_stamp = {}
    for fox, hazard, topic in transforms:
        assert (fox["parent_frame_id"], fox["child_frame_id"]) == ("wearnav_user", "wearnav_camera")
        stamp = hazard.header["capture_ns"]
        assert (fox["timestamp"]["sec"], fox["timestamp"]["nsec"]) == divmod(stamp, 10**9)
        a, b, c, d = hazard.body["plane_camera"]
        t, r = fox["translation"], fox["rotation"]
        assert (t["x"], t["y"], t["z"]) == pytest.approx((0, 0, d), abs=1e-6)
        q = [r["x"], r["y"], r["z"], r["w"]]
        assert np.linalg.norm(q) == pytest.approx(1, abs=1e-9)
        # the floor's normal, seen from the camera, is the user frame's up; the optical
        # axis points forward (bearing 0 of the scan is where the camera looks)
        assert rotate(q, np.array([[a, b, c]]))[0] == pytest.approx([0, 0, 1], abs=1e-5)
        axis = rotate(q, np.array([[0.0, 0.0, 1.0]]))[0]
        assert abs(axis[1]) < 1e-5 and axis[0] > 0, axis
        by_stamp[stamp] = (q, np.array([t["x"], t["y"], t["z"]]))
    assert len(by_stamp) == len(hazards)
    # each point cloud, put in the user frame by the transform of its own frame: its floor
    # lies at z = 0 and nothing below it (Foxglove draws it under the scan)
    clouds = foxglove_messages(recording, "foxglove.PointCloud")
    placed = 0
    for fox, depth, _ in clouds:
        place = by_stamp.get(depth.header["capture_ns"])
        if place is None:  # a frame the recorder heard no hazard for
            continue
        xyz = np.frombuffer(base64.b64decode(fox["data"]), dtype="<f4").reshape(-1, 3).astype(float)
        z = (rotate(place[0], xyz) + place[1])[:, 2]
        # measured: nothing below 2 cm under the floor; a fifth to four fifths of the
        # points within 2 cm of it (fewer as the walker nears a wall)
        assert z.min() > -0.1, f"a point {-z.min():.2f} m below the floor"
        assert abs(np.percentile(z, 5)) < 0.03, f"the lowest points at {np.percentile(z, 5):.2f} m, not on the floor"
        placed += 1
    assert placed >= len(clouds) - 2, f"{placed} of {len(clouds)} clouds had their frame's transform"


def test_each_frames_camera_place_puts_its_scan_on_the_walls_of_the_floor_plan_the_agent_localizes_on(recording, tmp_path):
    # the demo walks its default world, `approach`; its compute agent localizes on the
    # world's floor plan (walls only), which `wearnav map` writes
    plan = tmp_path / "approach"
    run = subprocess.run([str(WEARNAV), "map", "--world", "approach", "--out", str(plan)],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    meta = dict(line.split(": ", 1) for line in (plan / "floor0.yaml").read_text().splitlines())
    ox, oy, _ = json.loads(meta["origin"])
    res = float(meta["resolution"])
    width, height, pixels = read_pgm(plan / meta["image"])
    occupied = (255 - pixels.astype(float)) / 255 > float(meta["occupied_thresh"])

    def near_wall(x, y, within_m=0.15):
        k, col, row = math.ceil(within_m / res), int((x - ox) / res), height - 1 - int((y - oy) / res)
        r0, r1, c0, c1 = max(row - k, 0), min(row + k + 1, height), max(col - k, 0), min(col + k + 1, width)
        return r0 < r1 and c0 < c1 and bool(occupied[r0:r1, c0:c1].any())

    places = {}
    for fox, place, topic in foxglove_messages(recording, "foxglove.FrameTransform"):
        if topic != f"wearnav/{USER}/localization/camera/foxglove":
            continue
        stamp = place.header["capture_ns"]
        assert (fox["timestamp"]["sec"], fox["timestamp"]["nsec"]) == divmod(stamp, 10**9)
        assert (fox["parent_frame_id"], fox["child_frame_id"]) == ("map", "wearnav_user")
        t, r = fox["translation"], fox["rotation"]
        body = place.body
        assert (t["x"], t["y"], t["z"]) == pytest.approx((body["x_m"], body["y_m"], 0), abs=1e-6)
        assert (r["x"], r["y"]) == (0, 0)
        yaw = 2 * math.atan2(r["z"], r["w"])
        assert math.remainder(yaw - body["yaw_rad"], 2 * math.pi) == pytest.approx(0, abs=1e-6)
        assert body["floor"] == 0 and body["status"] in ("Tracking", "Converging"), body
        places[stamp] = body
    scans, truth = {}, {}
    with open(recording, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            if channel.topic == f"wearnav/{USER}/perception/scan":
                scan = decode(message.data)
                scans[scan.header["capture_ns"]] = scan.body
            elif channel.topic.endswith("/truth") and channel.message_encoding == "wearnav-bincode":
                t = decode(message.data)
                truth[t.header["capture_ns"]] = t.body
    assert len(places) >= 90, f"{len(places)} camera places in 5 s of 30 Hz frames"
    assert len(set(places) & set(scans)) >= len(scans) - 2, "a camera place for every frame's scan"
    # the camera's view is the walker's heading turned by the cane's sweep (measured:
    # within 1.9 degrees)
    for stamp, place in places.items():
        if stamp in truth:
            g = truth[stamp]
            view = g["yaw_rad"] + math.radians(g["sweep_deg"])
            assert abs(math.degrees(math.remainder(place["yaw_rad"] - view, 2 * math.pi))) < 5, (place, g)

    def on_walls(ahead_m):
        """The share of the scans' ranges, placed by their frame's camera place moved
        `ahead_m` along its view, that lie within 15 cm of a wall of the plan."""
        hits = total = 0
        for stamp, scan in scans.items():
            p = places.get(stamp)
            if p is None:
                continue
            x0 = p["x_m"] + ahead_m * math.cos(p["yaw_rad"])
            y0 = p["y_m"] + ahead_m * math.sin(p["yaw_rad"])
            for i, r in enumerate(scan["ranges_m"]):
                if math.isfinite(r):
                    a = p["yaw_rad"] + math.radians(scan["angle_min_deg"] + i * scan["angle_increment_deg"])
                    total += 1
                    hits += near_wall(x0 + r * math.cos(a), y0 + r * math.sin(a))
        assert total >= 1000, f"{total} ranges"
        return hits / total

    # measured: every range on the wall the walker faces; 30 cm off, none
    assert on_walls(0.0) >= 0.95
    assert on_walls(0.3) < 0.2 and on_walls(-0.3) < 0.2


def read_pgm(path):
    """(width, height, pixels top row first) of a binary 8-bit PGM."""
    data = path.read_bytes()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos)
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    assert fields[0] == b"P5" and fields[3] == b"255"
    width, height = int(fields[1]), int(fields[2])
    return width, height, np.frombuffer(data[pos + 1:pos + 1 + width * height], dtype=np.uint8).reshape(height, width)


def test_each_floor_of_the_map_is_a_foxglove_grid_with_the_cells_map_server_reads_from_its_image(recording):
    grids = {topic: fox for fox, _, topic in foxglove_messages(recording, "foxglove.Grid")}
    assert set(grids) == {f"wearnav/{USER}/map/floor0/foxglove", f"wearnav/{USER}/map/floor1/foxglove"}
    for level in (0, 1):
        fox = grids[f"wearnav/{USER}/map/floor{level}/foxglove"]
        meta = dict(line.split(": ", 1) for line in (ROOT / "maps" / "building" / f"floor{level}.yaml").read_text().splitlines())
        ox, oy, _ = json.loads(meta["origin"])
        assert (fox["pose"]["position"]["x"], fox["pose"]["position"]["y"]) == pytest.approx((ox, oy))
        assert fox["cell_size"]["x"] == fox["cell_size"]["y"] == pytest.approx(float(meta["resolution"]))
        width, height, pixels = read_pgm(ROOT / "maps" / "building" / meta["image"])
        assert (fox["column_count"], fox["row_stride"], fox["cell_stride"]) == (width, width, 1)
        cells = np.frombuffer(base64.b64decode(fox["data"]), dtype=np.int8).reshape(height, width)
        # map_server's trinary reading (negate 0): occupied above 0.65 of black, free
        # below 0.196, unknown between; the image's top row is the grid's last
        occupancy = (255 - pixels[::-1].astype(float)) / 255
        expected = np.where(occupancy > float(meta["occupied_thresh"]), 100,
                            np.where(occupancy < float(meta["free_thresh"]), 0, -1))
        assert (cells == expected).all(), f"floor {level}: {(cells != expected).sum()} cells differ"
        assert (cells == 100).sum() > 1000 and (cells == 0).sum() > 10000
