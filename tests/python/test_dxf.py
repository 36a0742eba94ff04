"""`wearnav map --dxf` on floor plans that ezdxf writes (a DXF library no one here
wrote): real processes, the built binary, its files read back here.

The office floor of `compute-agent/map/tests/data/make_floor_dxf.py` (walls, doors,
columns from a block, a rounded corner, door swings and furniture on their own layers,
TEXT and MTEXT names) must come out with walls where its lines are, rooms and doors
free, labels where its texts are, the same grid from millimetres and from metres, and
`wearnav plan` must find the route to a room through its door. A drawing from before
units were written (R12) is refused until told its unit; a damaged one is refused
naming the file and the line.
"""

import importlib.util
import json
import math
import os
import subprocess
import tomllib
from pathlib import Path

import pytest

ezdxf = pytest.importorskip("ezdxf")

ROOT = Path(__file__).resolve().parents[2]
#: The binary cargo built: target/debug, or under CARGO_TARGET_DIR when that is set.
TARGET = Path(os.environ.get("CARGO_TARGET_DIR", "target"))
WEARNAV = (TARGET if TARGET.is_absolute() else ROOT / TARGET) / "debug" / "wearnav"
GENERATOR = ROOT / "compute-agent" / "map" / "tests" / "data" / "make_floor_dxf.py"


def load_generator():
    spec = importlib.util.spec_from_file_location("make_floor_dxf", GENERATOR)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


FLOOR = load_generator()


@pytest.fixture(scope="module", autouse=True)
def built():
    if not WEARNAV.exists():
        pytest.fail(f"{WEARNAV} missing: run `cargo build --workspace` first")


def wearnav(*args, check=True):
    result = subprocess.run([str(WEARNAV), *map(str, args)], capture_output=True, text=True, timeout=120)
    if check and result.returncode != 0:
        pytest.fail(f"wearnav {' '.join(map(str, args))} exited {result.returncode}:\n{result.stderr}")
    return result


class FloorMap:
    """A map_server map as written: the YAML's resolution and origin, the PGM's pixels."""

    def __init__(self, yaml_path):
        fields = {}
        for line in Path(yaml_path).read_text().splitlines():
            key, _, value = line.partition(":")
            fields[key.strip()] = value.strip()
        self.resolution = float(fields["resolution"])
        self.origin = [float(v) for v in fields["origin"].strip("[]").split(",")]
        assert self.origin[2] == 0.0
        self.width, self.height, self.pixels = read_pgm(Path(yaml_path).parent / fields["image"])

    def at(self, x, y):
        """The pixel of map point (x, y): 0 occupied, 254 free, 205 unknown."""
        col = math.floor((x - self.origin[0]) / self.resolution)
        row = math.floor((y - self.origin[1]) / self.resolution)
        assert 0 <= col < self.width and 0 <= row < self.height, (x, y)
        # image row 0 is the top of the map (largest y)
        return self.pixels[(self.height - 1 - row) * self.width + col]


def read_pgm(path):
    data = Path(path).read_bytes()
    tokens, pos = [], 0
    while len(tokens) < 4:
        end = data.index(b"\n", pos)
        line, pos = data[pos:end], end + 1
        if not line.startswith(b"#"):
            tokens += line.split()
    assert tokens[0] == b"P5" and tokens[3] == b"255", tokens
    width, height = int(tokens[1]), int(tokens[2])
    pixels = data[pos : pos + width * height]
    assert len(pixels) == width * height
    return width, height, pixels


FREE, OCCUPIED, UNKNOWN = 254, 0, 205

#: Points on the floor's walls, metres (outer, corridor, partitions, rounded corner, columns).
WALL_POINTS = [
    (0.0, 2.0),
    (0.0, 9.0),
    (20.0, 5.0),
    (10.0, 0.0),
    (10.0, 12.0),
    (7.0, 2.5),
    (14.0, 2.5),
    (10.0, 9.5),
    (1.5, 5.0),
    (8.0, 7.0),
    (18.0 + math.sqrt(2), 10.0 + math.sqrt(2)),
    (3.15, 10.5),
    (6.85, 10.5),
]


def import_floor(tmp_path, units="mm", *args):
    dxf = tmp_path / f"floor-{units}.dxf"
    FLOOR.make_floor(str(dxf), units)
    out = tmp_path / f"out-{units}"
    result = wearnav("map", "--dxf", dxf, "--out", out, *args)
    return out, result


def test_walls_rooms_doors_and_labels_are_where_the_drawing_has_them(tmp_path):
    out, result = import_floor(tmp_path, "mm", "--wall-layers", "WALLS")
    assert "read in mm ($INSUNITS)" in result.stdout, result.stdout
    assert "not read: 1 DIMENSION, 1 HATCH" in result.stdout, result.stdout
    manifest = tomllib.loads((out / "building.toml").read_text())
    assert manifest["floor"] == [{"level": 0, "map": "floor0.yaml", "semantic": "floor0.toml"}]
    m = FloorMap(out / "floor0.yaml")
    assert m.resolution == 0.05
    for x, y in WALL_POINTS:
        assert m.at(x, y) == OCCUPIED, (x, y)
    for wall_y, x0, x1, room in FLOOR.DOORS:
        for k in range(1, 18):
            x = x0 + (x1 - x0) * k / 18
            assert m.at(x, wall_y) == FREE, f"door of {room} at x = {x}"
    for y in (5.55, 6.0, 6.45):
        assert m.at(0.0, y) == FREE, f"entrance at y = {y}"
    # inside rooms, under the table (FURNITURE is not a wall layer here), in a column
    for x, y in [(3.5, 2.5), (12.0, 6.0), (13.0, 9.0), (3.0, 10.5), (19.0, 11.0)]:
        assert m.at(x, y) == FREE, (x, y)
    # beyond the drawing
    assert m.at(-0.3, 6.0) == UNKNOWN
    assert m.at(10.0, 12.4) == UNKNOWN
    labels = {lab["name"]: lab for lab in tomllib.loads((out / "floor0.toml").read_text())["label"]}
    assert sorted(labels) == sorted(FLOOR.LABELS)
    for name, (x, y) in FLOOR.LABELS.items():
        assert abs(labels[name]["x"] - x) <= m.resolution and abs(labels[name]["y"] - y) <= m.resolution, name
        assert labels[name]["floor"] == 0
        assert m.at(x, y) == FREE, name


def test_the_plans_north_is_written_for_the_compass_and_none_said_is_none_written(tmp_path):
    out, result = import_floor(tmp_path, "mm", "--north-deg", "-30")
    assert "(north at 330.0° from +x)" in result.stdout, result.stdout
    assert tomllib.loads((out / "floor0.toml").read_text())["north_deg"] == 330.0
    out, result = import_floor(tmp_path, "m")
    assert "(no north: no compass is read on it)" in result.stdout, result.stdout
    assert "north_deg" not in tomllib.loads((out / "floor0.toml").read_text())


def test_millimetres_and_metres_give_the_same_map(tmp_path):
    mm, _ = import_floor(tmp_path, "mm")
    m, result = import_floor(tmp_path, "m")
    assert "read in m ($INSUNITS)" in result.stdout, result.stdout
    assert (mm / "floor0.pgm").read_bytes() == (m / "floor0.pgm").read_bytes()
    assert (mm / "floor0.yaml").read_text() == (m / "floor0.yaml").read_text()
    labels_mm = tomllib.loads((mm / "floor0.toml").read_text())["label"]
    labels_m = tomllib.loads((m / "floor0.toml").read_text())["label"]
    assert [lab["name"] for lab in labels_mm] == [lab["name"] for lab in labels_m]
    for a, b in zip(labels_mm, labels_m):
        assert abs(a["x"] - b["x"]) < 1e-9 and abs(a["y"] - b["y"]) < 1e-9, (a, b)


def plan(out, start, to, check=True):
    return wearnav(
        "plan",
        "--map",
        out / "floor0.yaml",
        "--semantic",
        out / "floor0.toml",
        "--from",
        f"{start[0]},{start[1]}",
        "--to",
        to,
        "--json",
        check=check,
    )


def crossings(waypoints, wall_y):
    """The x where the route crosses the line y = wall_y."""
    xs = []
    for (x0, y0), (x1, y1) in zip(waypoints, waypoints[1:]):
        if (y0 - wall_y) * (y1 - wall_y) < 0:
            xs.append(x0 + (wall_y - y0) / (y1 - y0) * (x1 - x0))
    return xs


def test_plan_goes_through_the_door_to_a_label_from_a_text(tmp_path):
    out, _ = import_floor(tmp_path, "mm", "--wall-layers", "WALLS")
    for room, wall_y, (x0, x1) in [("room 101", 5.0, (3.0, 3.9)), ("room 104", 7.0, (14.0, 14.9))]:
        route = json.loads(plan(out, (1.0, 6.0), room).stdout)
        assert route["to_label"] == room
        waypoints = route["waypoints"]
        assert math.dist(waypoints[-1], FLOOR.LABELS[room]) < 0.2, waypoints[-1]
        through = crossings(waypoints, wall_y)
        assert len(through) == 1 and x0 < through[0] < x1, f"{room}: crosses y = {wall_y} at {through}"
        assert route["length_m"] > math.dist((1.0, 6.0), FLOOR.LABELS[room])


def test_door_swings_on_a_wall_layer_close_their_doors(tmp_path):
    # every layer is a wall layer unless told otherwise: the swings' arcs shut the rooms
    out, result = import_floor(tmp_path, "mm")
    assert "on every layer" in result.stdout, result.stdout
    refused = plan(out, (1.0, 6.0), "room 101", check=False)
    assert refused.returncode != 0
    assert "room 101" not in refused.stdout


def test_r12_drawing_without_units_is_refused_until_told_then_read(tmp_path):
    doc = ezdxf.new("R12")  # R12 has no $INSUNITS
    msp = doc.modelspace()
    # a 6 x 4 m room as one closed POLYLINE whose east side bulges out by 1 m
    bulge = 2 * 1.0 / 4.0  # tan(angle / 4) = 2 sagitta / chord: 1 m out over the 4 m side
    msp.add_polyline2d([(0, 0, 0), (6, 0, bulge), (6, 4, 0), (0, 4, 0)], format="xyb", close=True)
    msp.add_text("store", height=0.25).set_placement((3, 2))
    dxf = tmp_path / "r12.dxf"
    doc.saveas(dxf)
    out = tmp_path / "r12"
    refused = wearnav("map", "--dxf", dxf, "--out", out, check=False)
    assert refused.returncode != 0
    assert "r12.dxf" in refused.stderr and "has no units" in refused.stderr, refused.stderr
    assert not out.exists()
    wearnav("map", "--dxf", dxf, "--out", out, "--units", "m", "--wall-thickness", "0.1")
    m = FloorMap(out / "floor0.yaml")
    for x, y in [(3.0, 0.0), (0.0, 2.0), (3.0, 4.0), (7.0, 2.0)]:
        assert m.at(x, y) == OCCUPIED, (x, y)
    for x, y in [(3.0, 2.0), (6.0, 2.0), (6.7, 2.0)]:
        assert m.at(x, y) == FREE, (x, y)
    labels = tomllib.loads((out / "floor0.toml").read_text())["label"]
    assert [(lab["name"], lab["x"], lab["y"]) for lab in labels] == [("store", 3.0, 2.0)]


def test_damaged_drawing_is_refused_naming_file_and_line(tmp_path):
    good = tmp_path / "good.dxf"
    FLOOR.make_floor(str(good), "mm")
    lines = good.read_text().splitlines(keepends=True)
    # the first LINE's end point: its x replaced by text
    at = next(i for i, line in enumerate(lines) if line.strip() == "LINE")
    x = next(i for i in range(at, len(lines)) if lines[i].strip() == "11") + 1
    lines[x] = "eleven\n"
    bad = tmp_path / "bad.dxf"
    bad.write_text("".join(lines))
    out = tmp_path / "bad"
    result = wearnav("map", "--dxf", bad, "--out", out, check=False)
    assert result.returncode != 0
    assert f"bad.dxf:{x + 1}: malformed DXF: group code 11" in result.stderr, result.stderr
    assert not out.exists()
    cut = tmp_path / "cut.dxf"
    cut.write_bytes(good.read_bytes()[: len(good.read_bytes()) // 2])
    result = wearnav("map", "--dxf", cut, "--out", out, check=False)
    assert result.returncode != 0 and "cut.dxf" in result.stderr and "cut short" in result.stderr, result.stderr


def test_world_and_dxf_are_one_or_the_other(tmp_path):
    result = wearnav("map", "--world", "corridor", "--dxf", "x.dxf", "--out", tmp_path, check=False)
    assert result.returncode == 2 and "cannot be used with" in result.stderr, result.stderr
    result = wearnav("map", "--world", "corridor", "--units", "mm", "--out", tmp_path, check=False)
    assert result.returncode == 2 and "'--world <WORLD>' cannot be used with '--units" in result.stderr, result.stderr
