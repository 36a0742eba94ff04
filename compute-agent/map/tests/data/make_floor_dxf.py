"""Writes floor.dxf: a small office floor as an architect's CAD tool would hand it over,
made with ezdxf (a DXF library no one here wrote), for `wearnav map --dxf` and its tests.

    python3 -m pip install ezdxf==1.4.5
    PYTHONHASHSEED=0 python3 compute-agent/map/tests/data/make_floor_dxf.py compute-agent/map/tests/data/floor.dxf

(`PYTHONHASHSEED=0`: ezdxf writes its CLASSES in set order; with it the file is the same
bytes every run.)

The floor, in metres (the file is in millimetres, `$INSUNITS` 4, DXF R2013):

    y=12 +-------------------+-------------------.
         |  room 103         |  room 104          \\   <- a rounded corner (a bulge)
         |  o           o    |     [table]         |   <- columns (INSERTs of a block)
    y=7  +----  ---------------------  ------------+   <- doors 0.9 m wide
   entrance   main corridor                        |
    y=5  +---  ------+------  ------+-----  -------+
         |  room 101 |  room 102    |  toilets     |
    y=0  +-----------+--------------+--------------+
        x=0         x=7            x=14           x=20

Layers: WALLS (walls, columns), DOORS (door leaves and swings), FURNITURE (a table),
TEXT (room names: TEXT centred, MTEXT with formatting codes), DIMS (a dimension),
HATCH (the toilets' floor). `make_floor(path, units)` writes the same floor in other
units (the Python tests compare millimetres with metres).
"""

import sys

import ezdxf
from ezdxf.enums import TextEntityAlignment

#: $INSUNITS code and drawing units per metre
UNITS = {"mm": (4, 1000.0), "cm": (5, 100.0), "m": (6, 1.0)}

#: Door openings in the corridor walls, metres: (wall y, from x, to x, label of the room)
DOORS = [
    (5.0, 3.0, 3.9, "room 101"),
    (5.0, 10.0, 10.9, "room 102"),
    (5.0, 16.0, 16.9, "toilets"),
    (7.0, 4.0, 4.9, "room 103"),
    (7.0, 14.0, 14.9, "room 104"),
]

#: Where each name is written (the middle of its text), metres
LABELS = {
    "room 101": (3.5, 2.5),
    "room 102": (10.5, 2.5),
    "toilets": (17.0, 2.5),
    "room 103": (5.0, 9.0),
    "room 104": (16.5, 9.5),
    "entrance": (1.0, 6.0),
    "main corridor": (10.0, 6.0),
}

#: Columns (a block of a 0.15 m radius circle), metres
COLUMNS = [(3.0, 10.5), (7.0, 10.5)]


def make_floor(path, units="mm", version="R2013"):
    """Writes the floor to `path` in `units` (mm, cm or m)."""
    code, k = UNITS[units]
    ezdxf.options.write_fixed_meta_data_for_testing = True  # no dates or GUIDs: same bytes every run
    doc = ezdxf.new(version, units=code)
    for name, colour in [("WALLS", 7), ("DOORS", 3), ("FURNITURE", 5), ("TEXT", 1), ("DIMS", 4), ("HATCH", 8)]:
        doc.layers.add(name, color=colour)
    msp = doc.modelspace()

    def p(x, y):
        return (x * k, y * k)

    walls = {"layer": "WALLS"}
    # outer walls: one open polyline from the entrance's top jamb round to its bottom
    # jamb; the north-east corner is a quarter circle (bulge tan(90/4), clockwise)
    bulge = -0.41421356237
    outline = [(0, 6.5, 0), (0, 12, 0), (18, 12, bulge), (20, 10, 0), (20, 0, 0), (0, 0, 0), (0, 5.5, 0)]
    msp.add_lwpolyline([(*p(x, y), b) for x, y, b in outline], format="xyb", close=False, dxfattribs=walls)
    # corridor walls, broken by the doors
    for wall_y in (5.0, 7.0):
        gaps = sorted((x0, x1) for y, x0, x1, _ in DOORS if y == wall_y)
        x = 0.0
        for x0, x1 in gaps:
            msp.add_line(p(x, wall_y), p(x0, wall_y), dxfattribs=walls)
            x = x1
        msp.add_line(p(x, wall_y), p(20, wall_y), dxfattribs=walls)
    # partitions between rooms
    for x, y0, y1 in [(7, 0, 5), (14, 0, 5), (10, 7, 12)]:
        msp.add_line(p(x, y0), p(x, y1), dxfattribs=walls)
    # columns: a block on layer 0, inserted on WALLS
    column = doc.blocks.new("COLUMN")
    column.add_circle((0, 0), 0.15 * k, dxfattribs={"layer": "0"})
    for x, y in COLUMNS:
        msp.add_blockref("COLUMN", p(x, y), dxfattribs={"layer": "WALLS"})
    # doors: a leaf standing open into the room and its swing
    for wall_y, x0, x1, _ in DOORS:
        into = -1 if wall_y == 5.0 else 1
        width = x1 - x0
        msp.add_line(p(x0, wall_y), p(x0, wall_y + into * width), dxfattribs={"layer": "DOORS"})
        start, end = (270, 360) if into < 0 else (0, 90)
        msp.add_arc(p(x0, wall_y), width * k, start, end, dxfattribs={"layer": "DOORS"})
    # a table in room 104
    table = [(12, 9), (14, 9), (14, 10), (12, 10)]
    msp.add_lwpolyline([p(x, y) for x, y in table], close=True, dxfattribs={"layer": "FURNITURE"})
    # names: TEXT centred on its point, MTEXT (attachment 5, middle centre) with codes
    for name in ["room 101", "room 102", "room 103", "room 104", "entrance"]:
        text = msp.add_text(name, height=0.3 * k, dxfattribs={"layer": "TEXT"})
        text.set_placement(p(*LABELS[name]), align=TextEntityAlignment.MIDDLE_CENTER)
    mtext = {"layer": "TEXT", "char_height": 0.3 * k, "attachment_point": 5}
    msp.add_mtext(r"{\fArial|b1|i0;toilets}", dxfattribs={**mtext, "insert": p(*LABELS["toilets"])})
    msp.add_mtext(r"\A1;main\P{\C1;corridor}", dxfattribs={**mtext, "insert": p(*LABELS["main corridor"])})
    # what a plan also holds and a floor map does not: a dimension, a hatch
    msp.add_linear_dim(base=p(0, -1), p1=p(0, 0), p2=p(20, 0), dxfattribs={"layer": "DIMS"}).render()
    hatch = msp.add_hatch(color=8, dxfattribs={"layer": "HATCH"})
    hatch.paths.add_polyline_path([p(14.2, 0.2), p(19.8, 0.2), p(19.8, 4.8), p(14.2, 4.8)], is_closed=True)
    doc.saveas(path)


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        sys.exit(f"usage: {sys.argv[0]} OUT.dxf [mm|cm|m]")
    make_floor(sys.argv[1], *sys.argv[2:])
