//! Floor plans from CAD: an architect's DXF drawing (AutoCAD's Drawing Exchange Format,
//! ASCII, R12 to R2018) as an occupancy grid and a semantic layer of its texts, the
//! same pair `wearnav map --world` writes for a simulated building.
//!
//! What is read, and what it becomes:
//!
//! | DXF (model space) | grid | semantic layer |
//! | --- | --- | --- |
//! | LINE, LWPOLYLINE, POLYLINE (2D or 3D; closed flag, bulges as arcs), ARC, CIRCLE on a wall layer | a band `wall_thickness_m` wide along the line, occupied | |
//! | TEXT, MTEXT on a label layer | | a label at the text's anchor, formatting stripped |
//! | INSERT of a block | the block's entities moved, scaled, rotated, mirrored and arrayed (MINSERT) as the INSERT says, nested up to [`MAX_BLOCK_DEPTH`]; a block entity on layer `0` takes the INSERT's layer | as for those entities |
//! | anything else (HATCH, DIMENSION, SPLINE, ELLIPSE, ATTRIB, POINT, ...) | not read; counted in [`DxfReport::skipped`] | |
//! | paper space (layouts, title blocks) | not read | |
//!
//! The grid: walls occupied; every other cell whose centre lies in the extent of the
//! walls and labels (their bounding box) free; the margin around it (`margin_m`, plus
//! half a wall) unknown. The planner neither routes nor snaps into unknown cells, so a
//! route never leaves the drawing: a drawing says nothing about what lies beyond it.
//! Inside the extent, outside the building's outline (the yard of an L-shaped plan) is
//! free too: a plan's lines do not say which side is indoors.
//!
//! A wall band ends where its line ends (no caps), so a door drawn as a 0.9 m gap
//! between two line ends stays 0.9 m wide; a cell is occupied when its centre is in the
//! band or the line passes through it, so a wall thinner than a cell has no gaps either.
//! `wall_thickness_m` is given to every line: a wall drawn as its centre line gets its
//! real thickness that way; for walls drawn as their two faces give a small thickness
//! (0.05 m), the space between the faces is walled in either way.
//!
//! Labels sit at the text's anchor: a TEXT's insertion point, or its alignment point
//! when it is justified (the middle of the two points for "aligned" and "fit"); an
//! MTEXT's insertion point. Centred texts (TEXT middle-centre, MTEXT attachment 5) put
//! the label at the text's middle. MTEXT codes (`\P`, `{\fArial|b0;...}`, `\S1/2;`, ...)
//! and TEXT's `%%d`-style codes are stripped to plain text; `\U+00E9` escapes decoded.
//!
//! Units: the header's `$INSUNITS` (1 inch, 2 feet, 4 mm, 5 cm, 6 m), unless the caller
//! gives [`DxfImport::units`], which wins (a warning says so when they differ). A
//! drawing with no units (`$INSUNITS` 0 or missing, as every R12 file) and none given is
//! refused rather than guessed: a plan in feet read as metres is a third of its size,
//! and nothing in the drawing would show it. Any drawing wider or taller than
//! [`MAX_EXTENT_M`] is refused too (a plan in millimetres read as metres is one).
//!
//! Text encoding: UTF-8 when the file is UTF-8 (R2007 and later always are), else
//! Windows-1252 (`ANSI_1252`, the usual code page of older files); other code pages
//! come out as Windows-1252 letters. Binary DXF is refused with a message.
//!
//! Why our own reader of the tag stream and not the `dxf` crate (ixmilia, 0.6.2,
//! measured on ezdxf 1.4.5's output): it panicked on 16 of 100,000 mutated drawings
//! (header dates overflowing `chrono`), refused ezdxf's R12 files, and cut texts
//! ending in a short escape in R2000/R2004 files (`hall\Pwest` read as `hall`); and it
//! would bring `chrono`, `image`, `uuid` and `num` into this pure crate. Bad input here
//! is a [`MapError::Dxf`] naming the file and the line; work and memory are bounded
//! ([`MAX_SEGMENTS`], [`MAX_INSTANCES`], [`crate::MAX_CELLS`]).

use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::Path;
use std::str::FromStr;

use crate::error::MapError;
use crate::grid::{check_resolution, check_size, Cell, OccupancyGrid, Origin};
use crate::semantic::{Label, SemanticLayer};

/// Cell size unless told otherwise, metres (as `wearnav map --world`: what ROS
/// `map_saver` writes for a typical laser map).
pub const DEFAULT_RESOLUTION_M: f64 = 0.05;

/// Wall thickness unless told otherwise, metres: an interior partition (a 100 mm stud
/// and a 12.5 mm board each side is 125 mm; masonry partitions 115-150 mm).
pub const DEFAULT_WALL_THICKNESS_M: f64 = 0.15;

/// Unknown cells kept around the drawing's extent unless told otherwise, metres.
pub const DEFAULT_MARGIN_M: f64 = 0.5;

/// The widest or tallest drawing read, metres: a floor plan is a building, and a plan
/// in millimetres read as metres is kilometres across.
pub const MAX_EXTENT_M: f64 = 2000.0;

/// The thickest wall or the widest margin accepted, metres.
pub const MAX_WALL_THICKNESS_M: f64 = 2.0;

/// The widest margin accepted, metres.
pub const MAX_MARGIN_M: f64 = 100.0;

/// Most wall segments after expanding blocks and arcs: bounds the work a small file of
/// nested INSERTs can ask for (a large real plan has tens of thousands).
pub const MAX_SEGMENTS: usize = 4_000_000;

/// Most block instances expanded (every INSERT, every MINSERT copy, nested ones too).
pub const MAX_INSTANCES: usize = 1_000_000;

/// Deepest nesting of blocks followed (a block inserting itself would never end).
pub const MAX_BLOCK_DEPTH: usize = 16;

/// Most segments one arc or circle becomes.
const MAX_ARC_SEGMENTS: usize = 1024;

/// Most warnings kept in a report (a drawing with 10,000 missing blocks needs one).
const MAX_WARNINGS: usize = 32;

/// Most distinct entity names counted in [`DxfReport::skipped`]; the rest count as `...`.
const MAX_SKIPPED_KINDS: usize = 64;

/// Coordinates beyond this many drawing units are refused while reading: far past any
/// building in any unit, far below where sums of them overflow.
const MAX_COORDINATE: f64 = 1e12;

/// A drawing unit (`$INSUNITS`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Units {
    /// `$INSUNITS` 4
    Millimetres,
    /// `$INSUNITS` 5
    Centimetres,
    /// `$INSUNITS` 6
    Metres,
    /// `$INSUNITS` 1
    Inches,
    /// `$INSUNITS` 2
    Feet,
}

impl Units {
    /// Metres per drawing unit.
    pub fn metres(self) -> f64 {
        match self {
            Units::Millimetres => 0.001,
            Units::Centimetres => 0.01,
            Units::Metres => 1.0,
            Units::Inches => 0.0254,
            Units::Feet => 0.3048,
        }
    }

    /// The unit of a `$INSUNITS` code, if it is one a floor plan is drawn in.
    pub fn from_insunits(code: i32) -> Option<Self> {
        match code {
            1 => Some(Units::Inches),
            2 => Some(Units::Feet),
            4 => Some(Units::Millimetres),
            5 => Some(Units::Centimetres),
            6 => Some(Units::Metres),
            _ => None,
        }
    }

    /// Its short name: `mm`, `cm`, `m`, `in`, `ft` (what [`FromStr`] reads).
    pub fn symbol(self) -> &'static str {
        match self {
            Units::Millimetres => "mm",
            Units::Centimetres => "cm",
            Units::Metres => "m",
            Units::Inches => "in",
            Units::Feet => "ft",
        }
    }
}

impl fmt::Display for Units {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.symbol())
    }
}

impl FromStr for Units {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "mm" | "millimetre" | "millimetres" | "millimeter" | "millimeters" => Ok(Units::Millimetres),
            "cm" | "centimetre" | "centimetres" | "centimeter" | "centimeters" => Ok(Units::Centimetres),
            "m" | "metre" | "metres" | "meter" | "meters" => Ok(Units::Metres),
            "in" | "inch" | "inches" => Ok(Units::Inches),
            "ft" | "foot" | "feet" => Ok(Units::Feet),
            _ => Err(format!("unknown unit {s:?}: give mm, cm, m, in or ft")),
        }
    }
}

/// How to turn a DXF drawing into a floor map. `Default` gives the documented defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct DxfImport {
    /// Metres per cell, in (0, 10] ([`DEFAULT_RESOLUTION_M`]).
    pub resolution_m: f64,
    /// Width of the band each wall line becomes, metres, in [0, 2]; 0 is one cell
    /// ([`DEFAULT_WALL_THICKNESS_M`]).
    pub wall_thickness_m: f64,
    /// Unknown cells around the extent, metres, in [0, 100] ([`DEFAULT_MARGIN_M`]).
    pub margin_m: f64,
    /// The drawing's unit; `None` takes the header's `$INSUNITS` (and refuses a
    /// drawing without one).
    pub units: Option<Units>,
    /// Layers whose lines are walls (names compared without case); `None`: every
    /// layer. Door swings, furniture and dimensions drawn as lines on other layers are
    /// walls too unless left out here.
    pub wall_layers: Option<Vec<String>>,
    /// Layers whose texts become labels (without case); `None`: every layer.
    pub label_layers: Option<Vec<String>>,
    /// The floor level the labels are on (0 = ground).
    pub level: i32,
}

impl Default for DxfImport {
    fn default() -> Self {
        Self {
            resolution_m: DEFAULT_RESOLUTION_M,
            wall_thickness_m: DEFAULT_WALL_THICKNESS_M,
            margin_m: DEFAULT_MARGIN_M,
            units: None,
            wall_layers: None,
            label_layers: None,
            level: 0,
        }
    }
}

/// A floor read from a drawing: the grid, the labels, and what was and was not read.
#[derive(Clone, Debug, PartialEq)]
pub struct DxfFloor {
    /// walls occupied, the drawing's extent free, the margin unknown
    pub grid: OccupancyGrid,
    /// one label per text on a label layer, on floor [`DxfImport::level`]
    pub semantic: SemanticLayer,
    /// what was read
    pub report: DxfReport,
}

/// What an import read, left out and assumed.
#[derive(Clone, Debug, PartialEq)]
pub struct DxfReport {
    /// `$ACADVER` (`AC1027` is R2013), empty when the header has none
    pub version: String,
    /// the unit the drawing was read in
    pub units: Units,
    /// the header's `$INSUNITS`, if any
    pub insunits: Option<i32>,
    /// the layers of the entities read (lines, curves, texts; in model space and in the
    /// blocks it inserts), sorted without case: what `wall_layers` may pick from
    pub layers: Vec<String>,
    /// entities drawn as walls (each block instance's count again)
    pub wall_entities: usize,
    /// the straight segments they became
    pub wall_segments: usize,
    /// entity name -> how many were not read (unknown kinds, paper space, empty texts),
    /// in model space and in the blocks it inserts (each copy again)
    pub skipped: BTreeMap<String, usize>,
    /// what the caller may want to know (units overridden, missing blocks, ...)
    pub warnings: Vec<String>,
    /// the extent of walls and labels, metres: [min x, min y, max x, max y]
    pub extent_m: [f64; 4],
}

impl DxfImport {
    /// Reads the DXF file at `path` (at most [`crate::map_server::MAX_FILE_BYTES`]).
    pub fn load(&self, path: &Path) -> Result<DxfFloor, MapError> {
        let bytes = crate::map_server::read_limited(path)?;
        self.parse(&bytes, path)
    }

    /// Reads a DXF file's bytes; `file` names it in errors.
    pub fn parse(&self, bytes: &[u8], file: &Path) -> Result<DxfFloor, MapError> {
        self.check(file)?;
        let drawing = Drawing::read(bytes, file)?;
        let err = |message: String| MapError::Dxf { file: file.to_path_buf(), line: 0, message };
        let (units, mut warnings) = self.units_of(&drawing, file)?;
        let walk = Walk::new(&drawing, file, self, units);

        // first pass: the extent, the labels, the budget
        let mut extent = Extent::default();
        let mut labels = Vec::new();
        let mut counts = Counts::default();
        walk.run(&mut counts, &mut warnings, &mut |item| match item {
            Item::Wall(a, b) => {
                extent.add(a);
                extent.add(b);
            }
            Item::Label(name, at) => {
                extent.add(at);
                labels.push(Label { name: name.to_string(), x: at[0], y: at[1], floor: self.level });
            }
        })?;
        let layers = counts.layer_names(&drawing);
        if counts.segments == 0 {
            return Err(err(no_walls_message(&layers, self)));
        }
        let [x0, y0, x1, y1] = extent.bounds();
        let (w, h) = (x1 - x0, y1 - y0);
        if !(w <= MAX_EXTENT_M && h <= MAX_EXTENT_M) {
            return Err(err(format!(
                "the drawing spans {w:.0} x {h:.0} m read in {units}, more than the {MAX_EXTENT_M} m a floor plan may: \
                 {}; if that is wrong, say which unit it is drawn in",
                match drawing.insunits {
                    Some(code) if Units::from_insunits(code).is_some() && self.units.is_none() => {
                        format!("its $INSUNITS {code} says {units}")
                    }
                    _ => format!("{units} as given"),
                }
            )));
        }

        // second pass: the walls into a grid covering the extent, the margin and half a wall
        let mut grid = self.empty_grid(&extent, file)?;
        let half_cells = self.wall_thickness_m / 2.0 / self.resolution_m;
        walk.run(&mut Counts::default(), &mut Vec::new(), &mut |item| {
            if let Item::Wall(a, b) = item {
                occupy_segment(&mut grid, a, b, half_cells);
            }
        })?;

        warnings.truncate(MAX_WARNINGS);
        let report = DxfReport {
            version: drawing.version.clone(),
            units,
            insunits: drawing.insunits,
            layers,
            wall_entities: counts.wall_entities,
            wall_segments: counts.segments,
            skipped: counts.skipped,
            warnings,
            extent_m: [x0, y0, x1, y1],
        };
        Ok(DxfFloor { grid, semantic: SemanticLayer { labels, ..SemanticLayer::default() }, report })
    }

    /// The options make sense: a resolution, thickness and margin in range.
    fn check(&self, file: &Path) -> Result<(), MapError> {
        check_resolution(file, self.resolution_m)?;
        let bad = |what: &str, value: f64, max: f64| MapError::Dxf {
            file: file.to_path_buf(),
            line: 0,
            message: format!("{what} {value} m is absurd: give a number in [0, {max}]"),
        };
        if !(0.0..=MAX_WALL_THICKNESS_M).contains(&self.wall_thickness_m) {
            return Err(bad("wall thickness", self.wall_thickness_m, MAX_WALL_THICKNESS_M));
        }
        if !(0.0..=MAX_MARGIN_M).contains(&self.margin_m) {
            return Err(bad("margin", self.margin_m, MAX_MARGIN_M));
        }
        Ok(())
    }

    /// The unit to read in: the caller's, else the header's; refused when neither says.
    fn units_of(&self, drawing: &Drawing, file: &Path) -> Result<(Units, Vec<String>), MapError> {
        let header = drawing.insunits.and_then(Units::from_insunits);
        let line = drawing.insunits_line;
        if let Some(given) = self.units {
            let mut warnings = Vec::new();
            if let Some(h) = header.filter(|h| *h != given) {
                warnings.push(format!("the drawing's $INSUNITS says {h}; read in {given} as told"));
            }
            return Ok((given, warnings));
        }
        match (header, drawing.insunits) {
            (Some(units), _) => Ok((units, Vec::new())),
            (None, Some(code)) if code != 0 => Err(MapError::Dxf {
                file: file.to_path_buf(),
                line,
                message: format!(
                    "$INSUNITS {code} is not a unit floor plans are read in (1 in, 2 ft, 4 mm, 5 cm, 6 m): \
                     say which unit the drawing is in"
                ),
            }),
            _ => Err(MapError::Dxf {
                file: file.to_path_buf(),
                line,
                message: "the drawing has no units ($INSUNITS is 0 or missing, as in every R12 file): say which \
                          unit it is drawn in (mm, cm, m, in or ft)"
                    .into(),
            }),
        }
    }

    /// Free over the extent, unknown around it: cells aligned on multiples of the
    /// resolution, checked against [`crate::MAX_CELLS`] before allocating.
    fn empty_grid(&self, extent: &Extent, file: &Path) -> Result<OccupancyGrid, MapError> {
        let res = self.resolution_m;
        let pad = self.margin_m + self.wall_thickness_m / 2.0;
        let [x0, y0, x1, y1] = extent.bounds();
        let origin_x = ((x0 - pad) / res).floor() * res;
        let origin_y = ((y0 - pad) / res).floor() * res;
        // finite and at most (2 km + 2 x 102 m) / res: fits in a u64 as f64
        let width = ((x1 + pad - origin_x) / res).ceil().max(1.0);
        let height = ((y1 + pad - origin_y) / res).ceil().max(1.0);
        check_size(file, width as u64, height as u64)?;
        let (width, height) = (width as usize, height as usize);
        let mut cells = vec![Cell::Unknown; width * height];
        for (row, line) in cells.chunks_exact_mut(width).enumerate() {
            let y = origin_y + (row as f64 + 0.5) * res;
            if y < y0 || y > y1 {
                continue;
            }
            for (col, cell) in line.iter_mut().enumerate() {
                let x = origin_x + (col as f64 + 0.5) * res;
                if x >= x0 && x <= x1 {
                    *cell = Cell::Free;
                }
            }
        }
        OccupancyGrid::new(width, height, res, Origin { x_m: origin_x, y_m: origin_y, yaw_rad: 0.0 }, cells)
    }
}

/// "no walls: ..." with the layers the drawing has, so the user can pick.
fn no_walls_message(layers: &[String], options: &DxfImport) -> String {
    let on = match &options.wall_layers {
        Some(layers) => format!("on layers {}", layers.join(", ")),
        None => "on any layer".to_string(),
    };
    let more = layers.len().saturating_sub(20);
    let layers = &layers[..layers.len() - more];
    let list = if layers.is_empty() {
        "it has no lines, curves or texts in model space".to_string()
    } else {
        format!(
            "its lines, curves and texts are on layers {}{}",
            layers.join(", "),
            if more > 0 { format!(" and {more} more") } else { String::new() }
        )
    };
    format!("no walls: no LINE, LWPOLYLINE, POLYLINE, ARC or CIRCLE {on} in model space; {list}")
}

// ---------------------------------------------------------------------------------
// The tag stream: a group code line, then a value line, to the end.

/// One group code and its value; `line` is the value's (1-based) line.
#[derive(Clone, Copy, Debug)]
struct Tag<'a> {
    code: i32,
    value: &'a str,
    line: usize,
}

impl Tag<'_> {
    /// The value with surrounding spaces removed (names, numbers).
    fn trimmed(&self) -> &str {
        self.value.trim()
    }

    fn is(&self, code: i32, value: &str) -> bool {
        self.code == code && self.trimmed().eq_ignore_ascii_case(value)
    }
}

struct Tags<'a> {
    text: &'a str,
    pos: usize,
    line: usize,
    peeked: Option<Tag<'a>>,
    file: &'a Path,
}

impl<'a> Tags<'a> {
    fn new(text: &'a str, file: &'a Path) -> Self {
        Self { text, pos: 0, line: 0, peeked: None, file }
    }

    fn error(&self, line: usize, message: String) -> MapError {
        MapError::Dxf { file: self.file.to_path_buf(), line, message: format!("malformed DXF: {message}") }
    }

    /// The next line without its end (`\n` or `\r\n`), or `None` at the end.
    fn next_line(&mut self) -> Option<&'a str> {
        if self.pos >= self.text.len() {
            return None;
        }
        let rest = &self.text[self.pos..];
        let (line, advance) = match rest.find('\n') {
            Some(i) => (&rest[..i], i + 1),
            None => (rest, rest.len()),
        };
        self.pos += advance;
        self.line += 1;
        Some(line.strip_suffix('\r').unwrap_or(line))
    }

    /// The next tag (comments, code 999, skipped); `None` at the end of the text.
    fn next(&mut self) -> Result<Option<Tag<'a>>, MapError> {
        if let Some(tag) = self.peeked.take() {
            return Ok(Some(tag));
        }
        loop {
            let Some(code_line) = self.next_line() else { return Ok(None) };
            let code_text = code_line.trim();
            if code_text.is_empty() && self.text[self.pos..].trim().is_empty() {
                return Ok(None); // blank lines at the very end
            }
            let code: i32 = code_text
                .parse()
                .map_err(|_| self.error(self.line, format!("group code {} is not an integer", shorten(code_text))))?;
            let code_line_no = self.line;
            let Some(value) = self.next_line() else {
                return Err(self.error(code_line_no, format!("group code {code} has no value: the file is cut short")));
            };
            if code != 999 {
                return Ok(Some(Tag { code, value, line: self.line }));
            }
        }
    }

    fn peek(&mut self) -> Result<Option<Tag<'a>>, MapError> {
        if self.peeked.is_none() {
            self.peeked = self.next()?;
        }
        Ok(self.peeked)
    }

    /// The next tag of the current group: `None` at a code 0 (left for the caller) or
    /// at the end.
    fn next_in_group(&mut self) -> Result<Option<Tag<'a>>, MapError> {
        match self.peek()? {
            Some(tag) if tag.code != 0 => {
                self.peeked = None;
                Ok(Some(tag))
            }
            _ => Ok(None),
        }
    }

    /// Skips the rest of the current group.
    fn skip_group(&mut self) -> Result<(), MapError> {
        while self.next_in_group()?.is_some() {}
        Ok(())
    }

    /// A number (codes 10-59, 210-239, ...): finite and within [`MAX_COORDINATE`].
    fn f64_of(&self, tag: &Tag) -> Result<f64, MapError> {
        match tag.trimmed().parse::<f64>() {
            Ok(v) if v.is_finite() && v.abs() <= MAX_COORDINATE => Ok(v),
            Ok(_) => {
                Err(self.error(tag.line, format!("group code {}: {} is out of range", tag.code, shorten(tag.value))))
            }
            Err(_) => {
                Err(self.error(tag.line, format!("group code {}: {} is not a number", tag.code, shorten(tag.value))))
            }
        }
    }

    /// An integer (codes 60-99, 170-179, 270-289, ...).
    fn i32_of(&self, tag: &Tag) -> Result<i32, MapError> {
        tag.trimmed().parse::<i32>().map_err(|_| {
            self.error(tag.line, format!("group code {}: {} is not an integer", tag.code, shorten(tag.value)))
        })
    }
}

/// At most 40 characters of a value, quoted, for a message.
fn shorten(value: &str) -> String {
    let short: String = value.chars().take(40).collect();
    if short.len() < value.len() {
        format!("{short:?}...")
    } else {
        format!("{short:?}")
    }
}

/// The file as text: UTF-8 when it is, else Windows-1252 (a UTF-8 BOM dropped).
fn decode(bytes: &[u8]) -> Cow<'_, str> {
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    match std::str::from_utf8(bytes) {
        Ok(text) => Cow::Borrowed(text),
        Err(_) => Cow::Owned(bytes.iter().map(|&b| windows_1252(b)).collect()),
    }
}

/// One byte of Windows-1252: Latin-1 except 0x80-0x9f.
fn windows_1252(b: u8) -> char {
    const HIGH: [u16; 32] = [
        0x20ac, 0x81, 0x201a, 0x192, 0x201e, 0x2026, 0x2020, 0x2021, 0x2c6, 0x2030, 0x160, 0x2039, 0x152, 0x8d, 0x17d,
        0x8f, 0x90, 0x2018, 0x2019, 0x201c, 0x201d, 0x2022, 0x2013, 0x2014, 0x2dc, 0x2122, 0x161, 0x203a, 0x153, 0x9d,
        0x17e, 0x178,
    ];
    match b {
        0x80..=0x9f => char::from_u32(HIGH[(b - 0x80) as usize] as u32).unwrap_or('?'),
        _ => b as char,
    }
}

// ---------------------------------------------------------------------------------
// The drawing: what of the file we use.

/// What an entity draws, in its own coordinates (OCS or WCS as the format says).
#[derive(Clone, Debug)]
enum Shape {
    /// LINE (WCS)
    Line([f64; 2], [f64; 2]),
    /// ARC (OCS), angles in degrees, counter-clockwise from start to end
    Arc { centre: [f64; 2], radius: f64, start_deg: f64, end_deg: f64 },
    /// CIRCLE (OCS)
    Circle { centre: [f64; 2], radius: f64 },
    /// LWPOLYLINE or POLYLINE: vertices (x, y, bulge to the next); 2D ones in OCS, 3D in WCS
    Poly { vertices: Vec<[f64; 3]>, closed: bool },
    /// TEXT (OCS) or MTEXT (WCS): plain text at its anchor
    Text { text: String, at: [f64; 2] },
    /// INSERT (OCS)
    Insert(Insert),
}

/// A block placed, scaled and rotated; a MINSERT's columns and rows of copies.
#[derive(Clone, Debug)]
struct Insert {
    block: String,
    at: [f64; 2],
    scale: [f64; 2],
    rotation_deg: f64,
    /// columns, rows
    copies: [u16; 2],
    /// column spacing, row spacing
    spacing: [f64; 2],
}

#[derive(Clone, Debug)]
struct Entity {
    shape: Shape,
    /// index into [`Drawing::layers`]
    layer: u32,
    /// the line of its `0` tag's value
    line: usize,
    /// the extrusion direction (210/220/230): the z axis of its OCS
    extrusion: Option<[f64; 3]>,
}

#[derive(Debug, Default)]
struct Block {
    base: [f64; 2],
    entities: Vec<Entity>,
    /// what of it is not read, counted for each copy inserted
    skipped: BTreeMap<String, usize>,
}

#[derive(Debug, Default)]
struct Drawing {
    version: String,
    insunits: Option<i32>,
    insunits_line: usize,
    entities: Vec<Entity>,
    /// by upper-case name (block names are not case-sensitive)
    blocks: HashMap<String, Block>,
    /// layer names as first written; entities index them
    layers: Vec<String>,
    /// upper-case layer name -> index
    layer_index: HashMap<String, u32>,
    /// what is not read in the section or block being read (model space when done)
    skipped: BTreeMap<String, usize>,
}

impl Drawing {
    fn read(bytes: &[u8], file: &Path) -> Result<Self, MapError> {
        if bytes.starts_with(b"AutoCAD Binary DXF") {
            return Err(MapError::Dxf {
                file: file.to_path_buf(),
                line: 1,
                message: "binary DXF is not read: save the drawing as ASCII DXF".into(),
            });
        }
        let text = decode(bytes);
        let mut tags = Tags::new(&text, file);
        let mut drawing = Drawing::default();
        let mut has_entities = false;
        loop {
            let Some(tag) = tags.next()? else {
                return Err(tags.error(
                    tags.line.max(1),
                    if tags.line == 0 {
                        "the file is empty".into()
                    } else {
                        "no 0/EOF at the end: the file is cut short".into()
                    },
                ));
            };
            if tag.is(0, "EOF") {
                break;
            }
            if !tag.is(0, "SECTION") {
                return Err(tags.error(
                    tag.line,
                    format!(
                        "expected 0/SECTION or 0/EOF, found {}/{}: is this a DXF file?",
                        tag.code,
                        shorten(tag.value)
                    ),
                ));
            }
            let name = match tags.next()? {
                Some(name) if name.code == 2 => name,
                _ => return Err(tags.error(tag.line, "a SECTION without a name (group code 2)".into())),
            };
            let section = name.trimmed().to_ascii_uppercase();
            match section.as_str() {
                "HEADER" => drawing.read_header(&mut tags, name.line)?,
                "BLOCKS" => drawing.read_blocks(&mut tags, name.line)?,
                "ENTITIES" => {
                    has_entities = true;
                    let entities = drawing.read_entities(&mut tags, "ENDSEC", "ENTITIES", name.line)?;
                    drawing.entities.extend(entities);
                }
                _ => skip_section(&mut tags, &section, name.line)?,
            }
        }
        if !has_entities {
            return Err(MapError::Dxf {
                file: file.to_path_buf(),
                line: 0,
                message: "no ENTITIES section: the file holds no drawing".into(),
            });
        }
        Ok(drawing)
    }

    fn read_header(&mut self, tags: &mut Tags, start: usize) -> Result<(), MapError> {
        let mut variable = String::new();
        loop {
            let tag = next_in_section(tags, "HEADER", start)?;
            match tag.code {
                0 if tag.is(0, "ENDSEC") => return Ok(()),
                0 => return Err(tags.error(tag.line, format!("0/{} inside the HEADER section", shorten(tag.value)))),
                9 => variable = tag.trimmed().to_ascii_uppercase(),
                70 if variable == "$INSUNITS" => {
                    self.insunits = Some(tags.i32_of(&tag)?);
                    self.insunits_line = tag.line;
                }
                1 if variable == "$ACADVER" => self.version = tag.trimmed().chars().take(16).collect(),
                _ => {}
            }
        }
    }

    fn read_blocks(&mut self, tags: &mut Tags, start: usize) -> Result<(), MapError> {
        loop {
            let tag = next_in_section(tags, "BLOCKS", start)?;
            if tag.is(0, "ENDSEC") {
                return Ok(());
            }
            if !tag.is(0, "BLOCK") {
                // stray tags between blocks: nothing of ours
                if tag.code == 0 {
                    check_not_structural(tags, &tag, "BLOCKS")?;
                    tags.skip_group()?;
                }
                continue;
            }
            let mut name = String::new();
            let mut base = [0.0; 2];
            while let Some(t) = tags.next_in_group()? {
                match t.code {
                    2 => name = t.trimmed().to_string(),
                    3 if name.is_empty() => name = t.trimmed().to_string(),
                    10 => base[0] = tags.f64_of(&t)?,
                    20 => base[1] = tags.f64_of(&t)?,
                    _ => {}
                }
            }
            let model_space = std::mem::take(&mut self.skipped);
            let entities = self.read_entities(tags, "ENDBLK", "BLOCK", tag.line)?;
            let skipped = std::mem::replace(&mut self.skipped, model_space);
            tags.skip_group()?; // ENDBLK's own tags
            self.blocks.insert(name.to_uppercase(), Block { base, entities, skipped });
        }
    }

    /// Entities up to `0/<end>` (consumed; its group is not).
    fn read_entities(
        &mut self,
        tags: &mut Tags,
        end: &str,
        section: &str,
        start: usize,
    ) -> Result<Vec<Entity>, MapError> {
        let mut entities = Vec::new();
        loop {
            let tag = next_in_section(tags, section, start)?;
            if tag.code != 0 {
                continue; // a stray tag before the first entity
            }
            if tag.is(0, end) {
                return Ok(entities);
            }
            check_not_structural(tags, &tag, section)?;
            let kind = tag.trimmed().to_ascii_uppercase();
            if let Some(entity) = self.read_entity(tags, &kind, tag.line)? {
                entities.push(entity);
            }
        }
    }

    /// One entity from its tags (POLYLINE with its VERTEX entities and SEQEND);
    /// `None` for what is not read (counted in `skipped`).
    fn read_entity(&mut self, tags: &mut Tags, kind: &str, line: usize) -> Result<Option<Entity>, MapError> {
        const READ: [&str; 8] = ["LINE", "CIRCLE", "ARC", "LWPOLYLINE", "POLYLINE", "TEXT", "MTEXT", "INSERT"];
        if !READ.contains(&kind) {
            // not read: its values are not looked at either
            tags.skip_group()?;
            if kind != "SEQEND" {
                self.skip(kind);
            }
            return Ok(None);
        }
        let mut f = Fields::default();
        let mut vertices: Vec<[f64; 3]> = Vec::new();
        while let Some(t) = tags.next_in_group()? {
            match (kind, t.code) {
                (_, 8) => f.layer = t.trimmed().to_string(),
                (_, 67) => f.paper = tags.i32_of(&t)? == 1,
                (_, 210..=230) if t.code % 10 == 0 => {
                    let v = tags.f64_of(&t)?;
                    f.extrusion.get_or_insert([0.0, 0.0, 1.0])[(t.code as usize - 210) / 10] = v;
                }
                ("LWPOLYLINE", 10) => vertices.push([tags.f64_of(&t)?, 0.0, 0.0]),
                ("LWPOLYLINE", 20) => {
                    if let Some(v) = vertices.last_mut() {
                        v[1] = tags.f64_of(&t)?;
                    }
                }
                ("LWPOLYLINE", 42) => {
                    if let Some(v) = vertices.last_mut() {
                        v[2] = tags.f64_of(&t)?;
                    }
                }
                ("TEXT" | "MTEXT", 1) => f.text = t.value.to_string(),
                // MTEXT's text past 250 characters: chunks of code 3 before the last (code 1)
                ("MTEXT", 3) if f.chunks.len() < 1 << 20 => f.chunks.push_str(t.value),
                ("INSERT", 2) => f.text = t.trimmed().to_string(),
                (_, 10 | 20 | 11 | 21 | 40..=45 | 50 | 51) => f.set_number(t.code, tags.f64_of(&t)?),
                (_, 70..=73) => f.set_integer(t.code, tags.i32_of(&t)?),
                _ => {}
            }
        }
        let layer = self.layer(&f.layer);
        let shape = match kind {
            "LINE" => Some(Shape::Line(f.point(10), f.point(11))),
            "CIRCLE" => Some(Shape::Circle { centre: f.point(10), radius: f.number(40, 0.0) }),
            "ARC" => Some(Shape::Arc {
                centre: f.point(10),
                radius: f.number(40, 0.0),
                start_deg: f.number(50, 0.0),
                end_deg: f.number(51, 0.0),
            }),
            "LWPOLYLINE" => Some(Shape::Poly { vertices, closed: f.integer(70, 0) & 1 != 0 }),
            "POLYLINE" => {
                if f.integer(70, 0) & 8 != 0 {
                    f.extrusion = None; // a 3D polyline's vertices are in world coordinates
                }
                self.read_vertices(tags, &f)?
            }
            "TEXT" => {
                let text = plain_text(&f.text, false);
                let justified = f.integer(72, 0) != 0 || f.integer(73, 0) != 0;
                let at = match (justified, f.has(11)) {
                    // aligned and fit: the text runs between the two points
                    (true, true) if matches!(f.integer(72, 0), 3 | 5) => {
                        let ([x0, y0], [x1, y1]) = (f.point(10), f.point(11));
                        [(x0 + x1) / 2.0, (y0 + y1) / 2.0]
                    }
                    (true, true) => f.point(11),
                    _ => f.point(10),
                };
                (!text.is_empty()).then_some(Shape::Text { text, at })
            }
            "MTEXT" => {
                f.chunks.push_str(&f.text);
                let text = plain_text(&f.chunks, true);
                // MTEXT's point is in world coordinates, whatever its extrusion
                f.extrusion = None;
                (!text.is_empty()).then_some(Shape::Text { text, at: f.point(10) })
            }
            "INSERT" => {
                // MINSERT copies: at most a 4096 x 4096 array (each copy is budgeted too)
                let copies = [70, 71].map(|code| f.integer(code, 1).clamp(1, 4096) as u16);
                Some(Shape::Insert(Insert {
                    block: std::mem::take(&mut f.text),
                    at: f.point(10),
                    scale: [f.number(41, 1.0), f.number(42, 1.0)],
                    rotation_deg: f.number(50, 0.0),
                    copies,
                    spacing: [f.number(44, 0.0), f.number(45, 0.0)],
                }))
            }
            _ => None,
        };
        let skipped = match (&shape, f.paper) {
            (Some(_), false) => None,
            (Some(_), true) => Some("(paper space)"),
            (None, _) if matches!(kind, "TEXT" | "MTEXT") => Some("(empty text)"),
            (None, _) => Some("POLYLINE (mesh)"),
        };
        if let Some(name) = skipped {
            self.skip(name);
            return Ok(None);
        }
        let extrusion = f.extrusion.filter(|e| *e != [0.0, 0.0, 1.0]);
        Ok(shape.map(|shape| Entity { shape, layer, line, extrusion }))
    }

    /// Counts an entity not read, by name (past [`MAX_SKIPPED_KINDS`] names as `...`).
    fn skip(&mut self, kind: &str) {
        count_skipped(&mut self.skipped, kind, 1);
    }

    /// A POLYLINE's VERTEX entities up to its SEQEND. Meshes (flags 16, 64) are not
    /// walls (`None`); a 3D polyline (flag 8) is in world coordinates.
    fn read_vertices(&mut self, tags: &mut Tags, f: &Fields) -> Result<Option<Shape>, MapError> {
        let flags = f.integer(70, 0);
        let mut vertices = Vec::new();
        while let Some(tag) = tags.peek()? {
            if tag.is(0, "SEQEND") {
                tags.next()?;
                tags.skip_group()?;
                break;
            }
            if !tag.is(0, "VERTEX") {
                break; // a POLYLINE without its SEQEND: what follows is the next entity
            }
            tags.next()?;
            let (mut v, mut vertex_flags) = ([0.0; 3], 0);
            while let Some(t) = tags.next_in_group()? {
                match t.code {
                    10 => v[0] = tags.f64_of(&t)?,
                    20 => v[1] = tags.f64_of(&t)?,
                    42 => v[2] = tags.f64_of(&t)?,
                    70 => vertex_flags = tags.i32_of(&t)?,
                    _ => {}
                }
            }
            // 16: a spline's frame control point, not on the curve; 128 without 64: a face
            if vertex_flags & 16 == 0 && !(vertex_flags & 128 != 0 && vertex_flags & 64 == 0) {
                vertices.push(v);
            }
        }
        Ok((flags & (16 | 64) == 0).then_some(Shape::Poly { vertices, closed: flags & 1 != 0 }))
    }

    /// The index of a layer by name (without case), added when new.
    fn layer(&mut self, name: &str) -> u32 {
        let name = if name.is_empty() { "0" } else { name };
        let key = name.to_uppercase();
        if let Some(&i) = self.layer_index.get(&key) {
            return i;
        }
        let i = self.layers.len() as u32;
        self.layers.push(name.to_string());
        self.layer_index.insert(key, i);
        i
    }
}

/// Adds `n` entities named `kind` not read (past [`MAX_SKIPPED_KINDS`] names as `...`).
fn count_skipped(skipped: &mut BTreeMap<String, usize>, kind: &str, n: usize) {
    let name: String = kind.chars().take(40).collect();
    let name = if skipped.len() < MAX_SKIPPED_KINDS || skipped.contains_key(&name) { name } else { "...".into() };
    *skipped.entry(name).or_default() += n;
}

/// A section's next tag; the end of the file inside it is an error.
fn next_in_section<'a>(tags: &mut Tags<'a>, section: &str, start: usize) -> Result<Tag<'a>, MapError> {
    tags.next()?.ok_or_else(|| {
        tags.error(start, format!("the file ends inside the {section} section that starts here: it is cut short"))
    })
}

/// 0/SECTION or 0/EOF inside a section: its 0/ENDSEC is missing.
fn check_not_structural(tags: &Tags, tag: &Tag, section: &str) -> Result<(), MapError> {
    if tag.is(0, "SECTION") || tag.is(0, "EOF") || tag.is(0, "ENDSEC") {
        return Err(tags.error(tag.line, format!("0/{} inside the {section} section", tag.trimmed())));
    }
    Ok(())
}

fn skip_section(tags: &mut Tags, section: &str, start: usize) -> Result<(), MapError> {
    loop {
        let tag = next_in_section(tags, section, start)?;
        if tag.is(0, "ENDSEC") {
            return Ok(());
        }
        if tag.is(0, "SECTION") || tag.is(0, "EOF") {
            return Err(tags.error(tag.line, format!("0/{} inside the {section} section", tag.trimmed())));
        }
    }
}

/// The tags of one entity that we use.
#[derive(Default)]
struct Fields {
    layer: String,
    paper: bool,
    extrusion: Option<[f64; 3]>,
    text: String,
    chunks: String,
    /// (code, value) of the numbers read: 10, 20, 11, 21, 40-45, 50, 51
    numbers: Vec<(i32, f64)>,
    /// (code, value) of the integers read: 70-73
    integers: Vec<(i32, i32)>,
}

impl Fields {
    fn set_number(&mut self, code: i32, v: f64) {
        match self.numbers.iter_mut().find(|(c, _)| *c == code) {
            Some(slot) => slot.1 = v,
            None => self.numbers.push((code, v)),
        }
    }

    fn set_integer(&mut self, code: i32, v: i32) {
        match self.integers.iter_mut().find(|(c, _)| *c == code) {
            Some(slot) => slot.1 = v,
            None => self.integers.push((code, v)),
        }
    }

    fn has(&self, code: i32) -> bool {
        self.numbers.iter().any(|(c, _)| *c == code)
    }

    fn number(&self, code: i32, default: f64) -> f64 {
        self.numbers.iter().find(|(c, _)| *c == code).map_or(default, |(_, v)| *v)
    }

    fn integer(&self, code: i32, default: i32) -> i32 {
        self.integers.iter().find(|(c, _)| *c == code).map_or(default, |(_, v)| *v)
    }

    /// The point of x code `code` (y is `code + 10`).
    fn point(&self, code: i32) -> [f64; 2] {
        [self.number(code, 0.0), self.number(code + 10, 0.0)]
    }
}

/// A label's text from a TEXT's or an MTEXT's value: formatting codes stripped,
/// escapes decoded, runs of white space (and line breaks) one space.
pub fn plain_text(raw: &str, mtext: bool) -> String {
    let mut out = String::with_capacity(raw.len().min(4096));
    let mut chars = raw.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\\' => {
                let Some(&code) = chars.peek() else { break };
                if code == 'U' || code == 'u' {
                    let hex: String = chars.clone().skip(1).take(5).collect();
                    if let Some(ch) = hex
                        .strip_prefix('+')
                        .filter(|h| h.len() == 4)
                        .and_then(|h| u32::from_str_radix(h, 16).ok())
                        .and_then(char::from_u32)
                    {
                        chars.nth(5);
                        out.push(ch);
                        continue;
                    }
                }
                if !mtext {
                    out.push('\\');
                    continue;
                }
                chars.next();
                match code {
                    'P' | 'X' | 'N' | '~' => out.push(' '),
                    '\\' | '{' | '}' => out.push(code),
                    'L' | 'l' | 'O' | 'o' | 'K' | 'k' => {}
                    // stacked text, "1/2", "x^2", "a#b": up to ';'
                    'S' => {
                        for c in chars.by_ref().take_while(|&c| c != ';') {
                            out.push(if c == '^' || c == '#' { '/' } else { c });
                        }
                    }
                    // font, height, colour, tracking, slant, width, alignment, paragraph: up to ';'
                    'f' | 'F' | 'H' | 'C' | 'c' | 'T' | 'Q' | 'W' | 'A' | 'p' => {
                        chars.by_ref().take_while(|&c| c != ';').for_each(drop);
                    }
                    other => out.push(other),
                }
            }
            '{' | '}' if mtext => {}
            '%' if chars.peek() == Some(&'%') => {
                chars.next();
                match chars.next() {
                    Some('d' | 'D') => out.push('°'),
                    Some('p' | 'P') => out.push('±'),
                    Some('c' | 'C') => out.push('⌀'),
                    Some('%') => out.push('%'),
                    Some('u' | 'U' | 'o' | 'O' | 'k' | 'K') => {}
                    Some(d) if d.is_ascii_digit() => {
                        let mut n = d.to_digit(10).unwrap_or(0);
                        for _ in 0..2 {
                            match chars.peek().and_then(|c| c.to_digit(10)) {
                                Some(v) => {
                                    n = n * 10 + v;
                                    chars.next();
                                }
                                None => break,
                            }
                        }
                        out.push(char::from_u32(n).filter(|c| !c.is_control()).unwrap_or(' '));
                    }
                    Some(other) => {
                        out.push_str("%%");
                        out.push(other);
                    }
                    None => out.push_str("%%"),
                }
            }
            c if c.is_control() => out.push(' '),
            c => out.push(c),
        }
    }
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

// ---------------------------------------------------------------------------------
// Walking the drawing: blocks expanded, curves flattened, into metres in the map frame.

/// `p -> m p + t`, 2D.
#[derive(Clone, Copy, Debug)]
struct Affine {
    m: [[f64; 2]; 2],
    t: [f64; 2],
}

impl Affine {
    fn scale(s: f64) -> Self {
        Self { m: [[s, 0.0], [0.0, s]], t: [0.0; 2] }
    }

    fn apply(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        [self.m[0][0] * x + self.m[0][1] * y + self.t[0], self.m[1][0] * x + self.m[1][1] * y + self.t[1]]
    }

    /// `self` after `inner`: `p -> self(inner(p))`.
    fn after(&self, inner: &Affine) -> Affine {
        let a = &self.m;
        let b = &inner.m;
        let m = [
            [a[0][0] * b[0][0] + a[0][1] * b[1][0], a[0][0] * b[0][1] + a[0][1] * b[1][1]],
            [a[1][0] * b[0][0] + a[1][1] * b[1][0], a[1][0] * b[0][1] + a[1][1] * b[1][1]],
        ];
        Affine { m, t: self.apply(inner.t) }
    }

    /// An upper bound of how much it stretches a length (the Frobenius norm).
    fn stretch(&self) -> f64 {
        self.m.iter().flatten().map(|v| v * v).sum::<f64>().sqrt()
    }

    /// An entity's OCS (the "arbitrary axis algorithm" of the DXF reference) projected
    /// on the world's x-y plane; `None` is the world's own.
    fn ocs(extrusion: Option<[f64; 3]>) -> Affine {
        let Some(n) = extrusion else { return Affine::scale(1.0) };
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if len.is_nan() || len <= 1e-12 {
            return Affine::scale(1.0);
        }
        let n = [n[0] / len, n[1] / len, n[2] / len];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        };
        let ax = if n[0].abs() < 1.0 / 64.0 && n[1].abs() < 1.0 / 64.0 {
            cross([0.0, 1.0, 0.0], n)
        } else {
            cross([0.0, 0.0, 1.0], n)
        };
        let l = (ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]).sqrt();
        let ax = [ax[0] / l, ax[1] / l, ax[2] / l];
        let ay = cross(n, ax);
        Affine { m: [[ax[0], ay[0]], [ax[1], ay[1]]], t: [0.0; 2] }
    }
}

/// What the walk finds: a wall segment or a label, metres in the map frame.
enum Item<'a> {
    Wall([f64; 2], [f64; 2]),
    Label(&'a str, [f64; 2]),
}

#[derive(Default)]
struct Counts {
    wall_entities: usize,
    segments: usize,
    instances: usize,
    /// by layer index: an entity read was on it
    layers_seen: Vec<bool>,
    /// entities not read, model space and each block copy
    skipped: BTreeMap<String, usize>,
}

impl Counts {
    /// The names of the layers seen, sorted without case.
    fn layer_names(&self, drawing: &Drawing) -> Vec<String> {
        let mut names: Vec<String> = self
            .layers_seen
            .iter()
            .zip(&drawing.layers)
            .filter(|(seen, _)| **seen)
            .map(|(_, name)| name.clone())
            .collect();
        names.sort_by_key(|l| l.to_uppercase());
        names
    }
}

/// The bounding box of what was found.
struct Extent {
    min: [f64; 2],
    max: [f64; 2],
}

impl Default for Extent {
    fn default() -> Self {
        Self { min: [f64::INFINITY; 2], max: [f64::NEG_INFINITY; 2] }
    }
}

impl Extent {
    fn add(&mut self, [x, y]: [f64; 2]) {
        self.min = [self.min[0].min(x), self.min[1].min(y)];
        self.max = [self.max[0].max(x), self.max[1].max(y)];
    }

    fn bounds(&self) -> [f64; 4] {
        [self.min[0], self.min[1], self.max[0], self.max[1]]
    }
}

struct Walk<'d> {
    drawing: &'d Drawing,
    file: &'d Path,
    units: Units,
    /// per layer index: its lines are walls, its texts labels
    walls: Vec<bool>,
    labels: Vec<bool>,
    /// longest chord error when flattening arcs, metres
    tolerance_m: f64,
}

impl<'d> Walk<'d> {
    fn new(drawing: &'d Drawing, file: &'d Path, options: &DxfImport, units: Units) -> Self {
        let pick = |names: &Option<Vec<String>>| -> Vec<bool> {
            drawing
                .layers
                .iter()
                .map(|l| names.as_ref().is_none_or(|names| names.iter().any(|n| n.trim().eq_ignore_ascii_case(l))))
                .collect()
        };
        Self {
            drawing,
            file,
            units,
            walls: pick(&options.wall_layers),
            labels: pick(&options.label_layers),
            tolerance_m: options.resolution_m / 4.0,
        }
    }

    fn run(
        &self,
        counts: &mut Counts,
        warnings: &mut Vec<String>,
        visit: &mut dyn FnMut(Item),
    ) -> Result<(), MapError> {
        let root = Affine::scale(self.units.metres());
        counts.layers_seen = vec![false; self.drawing.layers.len()];
        counts.skipped = self.drawing.skipped.clone();
        let mut state = WalkState { counts, warnings, visit };
        self.entities(&self.drawing.entities, &root, None, 0, &mut state)
    }

    fn error(&self, line: usize, message: String) -> MapError {
        MapError::Dxf { file: self.file.to_path_buf(), line, message }
    }

    fn entities(
        &self,
        entities: &[Entity],
        to_map: &Affine,
        inherited_layer: Option<u32>,
        depth: usize,
        state: &mut WalkState,
    ) -> Result<(), MapError> {
        for e in entities {
            let layer = match inherited_layer {
                Some(outer) if self.drawing.layers[e.layer as usize] == "0" => outer,
                _ => e.layer,
            };
            if let Some(seen) = state.counts.layers_seen.get_mut(layer as usize) {
                *seen = true;
            }
            let xf = to_map.after(&Affine::ocs(e.extrusion));
            match &e.shape {
                Shape::Text { text, at } if self.labels[layer as usize] => {
                    let p = xf.apply(*at);
                    self.finite(p, e.line)?;
                    (state.visit)(Item::Label(text, p));
                }
                Shape::Text { .. } => {}
                Shape::Insert(insert) => self.insert(e.line, insert, &xf, layer, depth, state)?,
                shape if self.walls[layer as usize] => {
                    state.counts.wall_entities += 1;
                    let tolerance = match xf.stretch() {
                        s if s > 1e-300 => self.tolerance_m / s,
                        _ => f64::INFINITY,
                    };
                    let mut previous: Option<[f64; 2]> = None;
                    let mut failed = None;
                    flatten(shape, tolerance, &mut |p, starts| {
                        let p = xf.apply(p);
                        if failed.is_some() {
                            return;
                        }
                        if !(p[0].is_finite() && p[1].is_finite()) {
                            failed = Some("coordinates out of range after scaling".to_string());
                            return;
                        }
                        if let (Some(a), false) = (previous, starts) {
                            state.counts.segments += 1;
                            if state.counts.segments > MAX_SEGMENTS {
                                failed = Some(format!(
                                    "more than {MAX_SEGMENTS} wall segments after expanding blocks and arcs"
                                ));
                                return;
                            }
                            (state.visit)(Item::Wall(a, p));
                        }
                        previous = Some(p);
                    });
                    if let Some(message) = failed {
                        return Err(self.error(e.line, message));
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// A block's entities where an INSERT places them (each copy of a MINSERT).
    fn insert(
        &self,
        line: usize,
        insert: &Insert,
        xf: &Affine,
        layer: u32,
        depth: usize,
        state: &mut WalkState,
    ) -> Result<(), MapError> {
        let Insert { block, at, scale, rotation_deg, copies, spacing } = insert;
        let Some(b) = self.drawing.blocks.get(&block.to_uppercase()) else {
            let warning =
                format!("INSERT of block {} (line {line}), which the drawing lacks: left out", shorten(block));
            if state.warnings.len() < MAX_WARNINGS && !state.warnings.contains(&warning) {
                state.warnings.push(warning);
            }
            return Ok(());
        };
        if depth >= MAX_BLOCK_DEPTH {
            return Err(self.error(
                line,
                format!(
                    "blocks nested more than {MAX_BLOCK_DEPTH} deep at block {}: does it insert itself?",
                    shorten(block)
                ),
            ));
        }
        let (s, c) = rotation_deg.to_radians().sin_cos();
        let rotate = Affine { m: [[c, -s], [s, c]], t: *at };
        for row in 0..copies[1] {
            for col in 0..copies[0] {
                state.counts.instances += 1;
                if state.counts.instances > MAX_INSTANCES {
                    return Err(self.error(line, format!("more than {MAX_INSTANCES} block instances to expand")));
                }
                // block coordinates -> the INSERT's OCS: minus the base point, scaled,
                // shifted to its cell of a MINSERT array, rotated, placed
                let local = Affine {
                    m: [[scale[0], 0.0], [0.0, scale[1]]],
                    t: [
                        -b.base[0] * scale[0] + col as f64 * spacing[0],
                        -b.base[1] * scale[1] + row as f64 * spacing[1],
                    ],
                };
                let to_map = xf.after(&rotate.after(&local));
                self.entities(&b.entities, &to_map, Some(layer), depth + 1, state)?;
                for (kind, n) in &b.skipped {
                    count_skipped(&mut state.counts.skipped, kind, *n);
                }
            }
        }
        Ok(())
    }

    fn finite(&self, [x, y]: [f64; 2], line: usize) -> Result<(), MapError> {
        if x.is_finite() && y.is_finite() {
            Ok(())
        } else {
            Err(self.error(line, "coordinates out of range after scaling".into()))
        }
    }
}

struct WalkState<'s> {
    counts: &'s mut Counts,
    warnings: &'s mut Vec<String>,
    visit: &'s mut dyn FnMut(Item),
}

/// The points of a wall shape in its own coordinates, `starts` true where a new
/// polyline begins; arcs as chords at most `tolerance` from the curve.
fn flatten(shape: &Shape, tolerance: f64, out: &mut dyn FnMut([f64; 2], bool)) {
    match shape {
        Shape::Line(a, b) => {
            out(*a, true);
            out(*b, false);
        }
        Shape::Circle { centre, radius } => {
            arc(*centre, *radius, 0.0, std::f64::consts::TAU, tolerance, true, out);
        }
        Shape::Arc { centre, radius, start_deg, end_deg } => {
            let start = start_deg.to_radians();
            let mut sweep = (end_deg - start_deg).rem_euclid(360.0).to_radians();
            if sweep == 0.0 {
                sweep = std::f64::consts::TAU; // start == end: the whole circle
            }
            arc(*centre, *radius, start, sweep, tolerance, true, out);
        }
        Shape::Poly { vertices, closed } => {
            let n = vertices.len();
            let Some(first) = vertices.first() else { return };
            out([first[0], first[1]], true);
            let edges = if *closed && n > 1 { n } else { n - 1 };
            for i in 0..edges {
                let [x0, y0, bulge] = vertices[i];
                let [x1, y1, _] = vertices[(i + 1) % n];
                bulge_edge([x0, y0], [x1, y1], bulge, tolerance, out);
            }
        }
        Shape::Text { .. } | Shape::Insert(_) => {}
    }
}

/// The edge from `a` to `b` of a polyline: straight, or an arc of included angle
/// `4 atan(bulge)` (counter-clockwise when positive). `a` was already given.
fn bulge_edge(a: [f64; 2], b: [f64; 2], bulge: f64, tolerance: f64, out: &mut dyn FnMut([f64; 2], bool)) {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let chord = dx.hypot(dy);
    if bulge.abs() < 1e-9 || chord < 1e-12 || !bulge.is_finite() {
        out(b, false);
        return;
    }
    let angle = 4.0 * bulge.atan();
    // the centre is on the chord's perpendicular bisector, left of a->b for a positive bulge
    let offset = (1.0 - bulge * bulge) / (4.0 * bulge);
    let centre = [(a[0] + b[0]) / 2.0 - dy * offset, (a[1] + b[1]) / 2.0 + dx * offset];
    let radius = (a[0] - centre[0]).hypot(a[1] - centre[1]);
    let start = (a[1] - centre[1]).atan2(a[0] - centre[0]);
    arc(centre, radius, start, angle, tolerance, false, out);
    out(b, false); // the exact end, whatever the rounding of the last chord
}

/// Points along an arc from `start` through `sweep` radians (counter-clockwise when
/// positive); the first point only when `first`.
fn arc(
    centre: [f64; 2],
    radius: f64,
    start: f64,
    sweep: f64,
    tolerance: f64,
    first: bool,
    out: &mut dyn FnMut([f64; 2], bool),
) {
    let radius = radius.abs();
    // the chord of angle step is at most `tolerance` from the arc; at least 8 per turn
    let step = if tolerance < radius { 2.0 * (1.0 - tolerance / radius).acos() } else { std::f64::consts::FRAC_PI_2 };
    let step = step.clamp(1e-9, std::f64::consts::FRAC_PI_4);
    let n = ((sweep.abs() / step).ceil() as usize).clamp(1, MAX_ARC_SEGMENTS);
    let at = |k: usize| {
        let t = start + sweep * k as f64 / n as f64;
        [centre[0] + radius * t.cos(), centre[1] + radius * t.sin()]
    };
    if first {
        out(at(0), true);
    }
    for k in 1..=n {
        out(at(k), false);
    }
}

// ---------------------------------------------------------------------------------
// Rasterising a wall.

/// Occupies the cells of the band of half width `half` (cells) along `a`-`b` (metres):
/// a cell whose centre lies in the band, or that the line passes through.
fn occupy_segment(grid: &mut OccupancyGrid, a: [f64; 2], b: [f64; 2], half: f64) {
    let (ax, ay) = grid.world_to_grid(a[0], a[1]);
    let (bx, by) = grid.world_to_grid(b[0], b[1]);
    let (dx, dy) = (bx - ax, by - ay);
    let length = dx.hypot(dy);
    if half > 0.0 && length > 1e-12 {
        let (nx, ny) = (-dy / length * half, dx / length * half);
        let corners = [[ax + nx, ay + ny], [bx + nx, by + ny], [bx - nx, by - ny], [ax - nx, ay - ny]];
        fill_convex(grid, &corners);
    }
    // a line ending on a cell's edge does not enter that cell: a touch is no overlap
    let shrink = if length > 2.0 * TOUCH_CELLS { TOUCH_CELLS / length } else { 0.0 };
    let (sx, sy) = (dx * shrink, dy * shrink);
    supercover(grid, [ax + sx, ay + sy], [bx - sx, by - sy]);
}

/// How far short of its ends the line is traced through cells, in cells: far below any
/// drawing's precision, far above the rounding of its coordinates.
const TOUCH_CELLS: f64 = 1e-6;

/// Occupies the cells whose centres lie in a convex polygon (grid units).
fn fill_convex(grid: &mut OccupancyGrid, corners: &[[f64; 2]; 4]) {
    let (w, h) = (grid.width() as i64, grid.height() as i64);
    let y_min = corners.iter().map(|c| c[1]).fold(f64::INFINITY, f64::min);
    let y_max = corners.iter().map(|c| c[1]).fold(f64::NEG_INFINITY, f64::max);
    let r0 = ((y_min - 0.5).ceil() as i64).max(0);
    let r1 = ((y_max - 0.5).floor() as i64).min(h - 1);
    for row in r0..=r1 {
        let yc = row as f64 + 0.5;
        let (mut x_min, mut x_max) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..4 {
            let (p, q) = (corners[i], corners[(i + 1) % 4]);
            if (p[1] - yc) * (q[1] - yc) > 0.0 {
                continue;
            }
            let xs = if p[1] == q[1] { [p[0], q[0]] } else { [p[0] + (yc - p[1]) / (q[1] - p[1]) * (q[0] - p[0]); 2] };
            for x in xs {
                x_min = x_min.min(x);
                x_max = x_max.max(x);
            }
        }
        if x_min > x_max {
            continue;
        }
        let c0 = ((x_min - 0.5).ceil() as i64).max(0);
        let c1 = ((x_max - 0.5).floor() as i64).min(w - 1);
        for col in c0..=c1 {
            grid.set(col as usize, row as usize, Cell::Occupied);
        }
    }
}

/// Occupies every cell the segment passes through (grid units; Amanatides & Woo 1987).
fn supercover(grid: &mut OccupancyGrid, a: [f64; 2], b: [f64; 2]) {
    let mut cell = [a[0].floor() as i64, a[1].floor() as i64];
    let end = [b[0].floor() as i64, b[1].floor() as i64];
    let d = [b[0] - a[0], b[1] - a[1]];
    let step = [d[0].signum() as i64, d[1].signum() as i64];
    let next_boundary = |i: usize| if step[i] > 0 { (cell[i] + 1) as f64 } else { cell[i] as f64 };
    let mut t_max = [0.0; 2];
    let mut t_delta = [f64::INFINITY; 2];
    for i in 0..2 {
        if d[i] != 0.0 {
            t_max[i] = (next_boundary(i) - a[i]) / d[i];
            t_delta[i] = (1.0 / d[i]).abs();
        } else {
            t_max[i] = f64::INFINITY;
        }
    }
    let steps = (end[0] - cell[0]).unsigned_abs() + (end[1] - cell[1]).unsigned_abs();
    let mark = |grid: &mut OccupancyGrid, [c, r]: [i64; 2]| {
        if c >= 0 && r >= 0 {
            grid.set(c as usize, r as usize, Cell::Occupied);
        }
    };
    mark(grid, cell);
    for _ in 0..steps {
        let i = if t_max[0] < t_max[1] { 0 } else { 1 };
        cell[i] += step[i];
        t_max[i] += t_delta[i];
        mark(grid, cell);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A DXF file: `$INSUNITS` (if any), the blocks, the entities.
    fn drawing(insunits: Option<i32>, blocks: &str, entities: &str) -> String {
        let header = insunits.map_or(String::new(), |u| format!("  9\n$INSUNITS\n 70\n{u}\n"));
        format!(
            "  0\nSECTION\n  2\nHEADER\n  9\n$ACADVER\n  1\nAC1009\n{header}  0\nENDSEC\n\
             0\nSECTION\n2\nBLOCKS\n{blocks}0\nENDSEC\n\
             0\nSECTION\n2\nENTITIES\n{entities}0\nENDSEC\n0\nEOF\n"
        )
    }

    fn line(layer: &str, [x0, y0]: [f64; 2], [x1, y1]: [f64; 2]) -> String {
        format!("0\nLINE\n8\n{layer}\n10\n{x0}\n20\n{y0}\n30\n0.0\n11\n{x1}\n21\n{y1}\n31\n0.0\n")
    }

    /// The four walls of a `w` x `h` room with its corner at the origin, scaled.
    fn room(w: f64, h: f64, scale: f64) -> String {
        let p = |x: f64, y: f64| [x * scale, y * scale];
        [
            line("WALLS", p(0.0, 0.0), p(w, 0.0)),
            line("WALLS", p(w, 0.0), p(w, h)),
            line("WALLS", p(w, h), p(0.0, h)),
            line("WALLS", p(0.0, h), p(0.0, 0.0)),
        ]
        .concat()
    }

    fn text(layer: &str, value: &str, [x, y]: [f64; 2]) -> String {
        format!("0\nTEXT\n8\n{layer}\n10\n{x}\n20\n{y}\n40\n0.2\n1\n{value}\n")
    }

    fn import(text: &str) -> Result<DxfFloor, MapError> {
        DxfImport::default().parse(text.as_bytes(), Path::new("plan.dxf"))
    }

    fn at(floor: &DxfFloor, x: f64, y: f64) -> Cell {
        let (c, r) = floor.grid.world_to_cell(x, y).expect("inside the grid");
        floor.grid.get(c, r).expect("inside the grid")
    }

    #[test]
    fn square_room_has_walls_on_its_lines_free_floor_inside_and_unknown_around() {
        let f = import(&drawing(Some(6), "", &room(4.0, 3.0, 1.0))).unwrap();
        for (x, y) in [(0.0, 1.5), (4.0, 1.5), (2.0, 0.0), (2.0, 3.0), (0.06, 1.5), (2.0, 2.94)] {
            assert_eq!(at(&f, x, y), Cell::Occupied, "({x}, {y})");
        }
        for (x, y) in [(2.0, 1.5), (0.2, 0.2), (3.8, 2.8)] {
            assert_eq!(at(&f, x, y), Cell::Free, "({x}, {y})");
        }
        // beyond the wall band (0.075 m) lies the margin: unknown, 0.5 m of it
        for (x, y) in [(-0.2, 1.5), (4.3, 1.5), (2.0, -0.5), (-0.5, -0.5)] {
            assert_eq!(at(&f, x, y), Cell::Unknown, "({x}, {y})");
        }
        let o = f.grid.origin();
        assert!((o.x_m + 0.6).abs() < 1e-9 && (o.y_m + 0.6).abs() < 1e-9, "{o:?}");
        assert_eq!((f.grid.width(), f.grid.height()), (104, 84));
        assert_eq!(f.report.units, Units::Metres);
        assert_eq!((f.report.wall_entities, f.report.wall_segments), (4, 4));
        assert_eq!(f.report.extent_m, [0.0, 0.0, 4.0, 3.0]);
        assert_eq!(f.report.version, "AC1009");
        assert!(f.semantic.labels.is_empty());
    }

    #[test]
    fn a_wall_thinner_than_a_cell_still_has_no_gap() {
        let options = DxfImport { wall_thickness_m: 0.0, resolution_m: 0.1, ..DxfImport::default() };
        let diagonal = line("0", [0.013, 0.021], [3.0, 2.0]);
        let f = options.parse(drawing(Some(6), "", &diagonal).as_bytes(), Path::new("d.dxf")).unwrap();
        // every cell the line crosses, and 4-connected: walking along it never leaves the wall
        for k in 0..300 {
            let t = k as f64 / 300.0;
            assert_eq!(at(&f, 0.013 + 2.987 * t, 0.021 + 1.979 * t), Cell::Occupied, "t = {t}");
        }
    }

    #[test]
    fn a_door_gap_between_two_line_ends_stays_as_wide_as_drawn() {
        // a room whose wall along y = 0 runs from x = 0 to 2, leaves a 0.9 m gap, then on to 4
        let walls = [
            line("W", [0.0, 0.0], [2.0, 0.0]),
            line("W", [2.9, 0.0], [4.0, 0.0]),
            line("W", [4.0, 0.0], [4.0, 3.0]),
            line("W", [4.0, 3.0], [0.0, 3.0]),
            line("W", [0.0, 3.0], [0.0, 0.0]),
        ]
        .concat();
        let f = import(&drawing(Some(6), "", &walls)).unwrap();
        assert_eq!(at(&f, 1.97, 0.0), Cell::Occupied);
        assert_eq!(at(&f, 2.93, 0.0), Cell::Occupied);
        for k in 0..17 {
            let x = 2.03 + 0.05 * k as f64;
            assert_eq!(at(&f, x, 0.0), Cell::Free, "x = {x}");
        }
    }

    #[test]
    fn closed_lwpolyline_with_a_bulge_walls_its_arc_and_its_closing_edge() {
        // a 4 x 4 square whose top edge, right to left, bulges up as a half circle
        let poly = |closed: i32| {
            format!(
                "0\nLWPOLYLINE\n8\nWALLS\n90\n4\n70\n{closed}\n10\n0\n20\n0\n10\n4\n20\n0\n10\n4\n20\n4\n42\n1.0\n\
                 10\n0\n20\n4\n"
            )
        };
        let f = import(&drawing(Some(6), "", &poly(1))).unwrap();
        let (s, c) = 45f64.to_radians().sin_cos();
        for (x, y) in [(2.0, 6.0), (2.0 + 2.0 * c, 4.0 + 2.0 * s), (4.0, 4.0), (0.0, 2.0), (2.0, 0.0)] {
            assert_eq!(at(&f, x, y), Cell::Occupied, "({x}, {y})");
        }
        for (x, y) in [(2.0, 4.0), (2.0, 5.5), (2.0, 2.0)] {
            assert_eq!(at(&f, x, y), Cell::Free, "({x}, {y})");
        }
        assert!(f.report.wall_segments > 8, "the arc is several chords: {}", f.report.wall_segments);
        // open: no edge from (0, 4) back to (0, 0)
        let open = import(&drawing(Some(6), "", &poly(0))).unwrap();
        assert_eq!(at(&open, 0.0, 2.0), Cell::Free);
    }

    #[test]
    fn polyline_vertices_arcs_and_circles_are_walls() {
        // R12's POLYLINE: VERTEX entities to SEQEND, closed, one bulge of -1 (clockwise)
        let polyline = "0\nPOLYLINE\n8\nW\n66\n1\n70\n1\n\
                        0\nVERTEX\n8\nW\n10\n0\n20\n0\n\
                        0\nVERTEX\n8\nW\n10\n4\n20\n4\n42\n-1\n\
                        0\nVERTEX\n8\nW\n10\n4\n20\n0\n\
                        0\nSEQEND\n8\nW\n";
        let arc = "0\nARC\n8\nW\n10\n10\n20\n0\n40\n2\n50\n0\n51\n90\n";
        let circle = "0\nCIRCLE\n8\nW\n10\n10\n20\n-5\n40\n1\n";
        let f = import(&drawing(Some(6), "", &[polyline, arc, circle].concat())).unwrap();
        // the bulge from (4, 4) down to (4, 0) is clockwise: a half circle out to x = 6
        let (s, c) = 45f64.to_radians().sin_cos();
        let arc_45 = (4.0 + 2.0 * c, 2.0 + 2.0 * s);
        let arc_entity_45 = (10.0 + 2f64.sqrt(), 2f64.sqrt());
        for (x, y) in [(6.0, 2.0), arc_45, (2.0, 2.0), (2.0, 0.0), (12.0, 0.0), (10.05, 1.99), arc_entity_45] {
            assert_eq!(at(&f, x, y), Cell::Occupied, "({x}, {y})");
        }
        for (x, y) in [(10.0, -4.0), (11.0, -5.0), (9.0, -5.0)] {
            assert_eq!(at(&f, x, y), Cell::Occupied, "circle ({x}, {y})");
        }
        for (x, y) in [(4.0, 2.0), (3.0, 1.0), (8.0, 0.0), (10.0, -5.0), (10.0 - 2f64.sqrt(), 2f64.sqrt())] {
            assert_eq!(at(&f, x, y), Cell::Free, "({x}, {y})");
        }
    }

    #[test]
    fn millimetres_and_metres_give_the_same_grid_and_labels() {
        let metres = drawing(Some(6), "", &[room(5.0, 4.0, 1.0), text("T", "room 101", [2.5, 2.0])].concat());
        let millimetres =
            drawing(Some(4), "", &[room(5.0, 4.0, 1000.0), text("T", "room 101", [2500.0, 2000.0])].concat());
        let (m, mm) = (import(&metres).unwrap(), import(&millimetres).unwrap());
        assert_eq!(m.grid, mm.grid);
        assert_eq!(m.semantic, mm.semantic);
        assert_eq!(mm.report.units, Units::Millimetres);
        // and a unitless drawing read in millimetres as told
        let unitless = drawing(None, "", &room(5.0, 4.0, 1000.0));
        let told = DxfImport { units: Some(Units::Millimetres), ..DxfImport::default() };
        assert_eq!(told.parse(unitless.as_bytes(), Path::new("u.dxf")).unwrap().grid, m.grid);
        // told otherwise than the header: read as told, with a warning
        let as_metres = DxfImport { units: Some(Units::Metres), ..DxfImport::default() };
        let e = as_metres.parse(millimetres.as_bytes(), Path::new("mm.dxf")).unwrap_err().to_string();
        assert!(e.contains("spans 5000 x 4000 m read in m") && e.contains("m as given"), "{e}");
        let e = import(&drawing(Some(6), "", &room(5000.0, 4000.0, 1.0))).unwrap_err().to_string();
        assert!(e.contains("its $INSUNITS 6 says m"), "{e}");
        let feet = DxfImport { units: Some(Units::Feet), ..DxfImport::default() };
        let f = feet.parse(metres.as_bytes(), Path::new("m.dxf")).unwrap();
        assert_eq!(f.report.warnings, ["the drawing's $INSUNITS says m; read in ft as told"]);
        assert!((f.semantic.labels[0].x - 2.5 * 0.3048).abs() < 1e-12);
    }

    #[test]
    fn text_labels_sit_at_their_anchor() {
        let justified = "0\nTEXT\n8\nTEXT\n10\n1\n20\n1\n11\n3\n21\n2\n72\n1\n73\n2\n40\n0.3\n1\nentrance\n";
        let aligned = "0\nTEXT\n8\nTEXT\n10\n0\n20\n0\n11\n2\n21\n0\n72\n5\n1\nfit\n";
        let entities = [room(5.0, 4.0, 1.0), text("TEXT", "room 101", [1.0, 1.0]), justified.into(), aligned.into()];
        let f = import(&drawing(Some(6), "", &entities.concat())).unwrap();
        let place = |name: &str| {
            let l = f.semantic.label(name).unwrap_or_else(|| panic!("{name}: {:?}", f.semantic.labels));
            (l.x, l.y, l.floor)
        };
        assert_eq!(place("room 101"), (1.0, 1.0, 0));
        assert_eq!(place("entrance"), (3.0, 2.0, 0));
        assert_eq!(place("fit"), (1.0, 0.0, 0));
        // a label outside the walls widens the free extent to it
        let outside = import(&drawing(Some(6), "", &[room(5.0, 4.0, 1.0), text("T", "yard", [7.0, 2.0])].concat()));
        let outside = outside.unwrap();
        assert_eq!(at(&outside, 6.9, 2.0), Cell::Free);
        assert_eq!(outside.report.extent_m, [0.0, 0.0, 7.0, 4.0]);
    }

    #[test]
    fn mtext_formatting_is_stripped_to_plain_text() {
        for (raw, plain) in [
            (r"{\fArial|b0|i0|c0|p34;Big} hall\Pwest", "Big hall west"),
            (r"\A1;{\H0.7x;\C1;room} 2\~14", "room 2 14"),
            (r"\LUnder\l and \Oover\o \Kstruck\k", "Under and over struck"),
            (r"caf\U+00E9 \\ \{x\}", r"café \ {x}"),
            (r"\S1/2; door\S3^4;", "1/2 door3/4"),
            (r"{\fTimes New Roman|b1;\pxqc;toilets}", "toilets"),
            ("  \\P\\P  ", ""),
            (r"\", ""),
        ] {
            assert_eq!(plain_text(raw, true), plain, "{raw}");
        }
        for (raw, plain) in [
            ("90%%d corner", "90° corner"),
            ("%%uroom%%u 7 %%p1", "room 7 ±1"),
            (r"a\b \U+00FCber", r"a\b über"),
            ("100%%%", "100%"),
            ("%%065", "A"),
        ] {
            assert_eq!(plain_text(raw, false), plain, "{raw}");
        }
        // an MTEXT entity: chunks of code 3 come before the last of code 1
        let mtext = "0\nMTEXT\n8\nTEXT\n10\n2\n20\n3\n71\n5\n3\n{\\fArial|b1;meeting \n1\nroom}\\Pnorth\n";
        let f = import(&drawing(Some(6), "", &[room(5.0, 4.0, 1.0), mtext.into()].concat())).unwrap();
        assert_eq!(f.semantic.labels, [Label { name: "meeting room north".into(), x: 2.0, y: 3.0, floor: 0 }]);
    }

    #[test]
    fn layers_pick_the_walls_and_the_labels() {
        let entities = [
            room(5.0, 4.0, 1.0),
            line("Furniture", [1.0, 1.0], [2.0, 1.0]),
            text("TEXT", "room 101", [2.5, 2.0]),
            text("NOTES", "check this", [3.0, 3.0]),
        ]
        .concat();
        let all = import(&drawing(Some(6), "", &entities)).unwrap();
        assert_eq!(at(&all, 1.5, 1.0), Cell::Occupied);
        assert_eq!(all.semantic.labels.len(), 2);
        assert_eq!(all.report.layers, ["Furniture", "NOTES", "TEXT", "WALLS"]);
        let picked = DxfImport {
            wall_layers: Some(vec!["walls".into()]),
            label_layers: Some(vec!["Text".into()]),
            ..DxfImport::default()
        };
        let f = picked.parse(drawing(Some(6), "", &entities).as_bytes(), Path::new("p.dxf")).unwrap();
        assert_eq!(at(&f, 1.5, 1.0), Cell::Free);
        assert_eq!(f.semantic.labels.len(), 1);
        let none = DxfImport { wall_layers: Some(vec!["A-WALL".into()]), ..DxfImport::default() };
        let e = none.parse(drawing(Some(6), "", &entities).as_bytes(), Path::new("p.dxf")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "p.dxf: no walls: no LINE, LWPOLYLINE, POLYLINE, ARC or CIRCLE on layers A-WALL in model space; \
             its lines, curves and texts are on layers Furniture, NOTES, TEXT, WALLS"
        );
    }

    #[test]
    fn inserted_blocks_are_placed_scaled_rotated_and_take_the_insert_layer() {
        // a block of one 1 m line along x on layer 0, base point (1, 0)
        let block = "0\nBLOCK\n8\n0\n2\nseg\n70\n0\n10\n1\n20\n0\n\
                     0\nLINE\n8\n0\n10\n1\n20\n0\n11\n2\n21\n0\n\
                     0\nENDBLK\n8\n0\n";
        // at (5, 5), scale 2, turned 90 degrees: a wall from (5, 5) to (5, 7)
        let insert = "0\nINSERT\n8\nWALLS\n2\nSEG\n10\n5\n20\n5\n41\n2\n42\n2\n50\n90\n";
        // a MINSERT of 3 columns 2 m apart, unturned: walls (0, 9)-(1, 9), (2, 9)-(3, 9), ...
        let array = "0\nINSERT\n8\nWALLS\n2\nseg\n10\n0\n20\n9\n70\n3\n44\n2\n";
        let missing = "0\nINSERT\n8\nWALLS\n2\nnowhere\n10\n0\n20\n0\n";
        let options = DxfImport { wall_layers: Some(vec!["WALLS".into()]), ..DxfImport::default() };
        let walls = room(10.0, 10.0, 1.0);
        let text = drawing(Some(6), block, &[walls.as_str(), insert, array, missing].concat());
        let f = options.parse(text.as_bytes(), Path::new("b.dxf")).unwrap();
        for (x, y) in [(5.0, 5.5), (5.0, 6.9), (0.5, 9.0), (2.5, 9.0), (4.5, 9.0)] {
            assert_eq!(at(&f, x, y), Cell::Occupied, "({x}, {y})");
        }
        for (x, y) in [(5.0, 4.8), (5.0, 7.2), (6.0, 6.0), (1.5, 9.0), (3.5, 9.0)] {
            assert_eq!(at(&f, x, y), Cell::Free, "({x}, {y})");
        }
        assert_eq!(f.report.wall_entities, 8);
        assert!(f.report.warnings[0].contains("\"nowhere\""), "{:?}", f.report.warnings);
    }

    #[test]
    fn a_mirrored_frame_and_paper_space_and_unknown_entities() {
        // extrusion (0, 0, -1): the OCS x axis points along world -x
        let circle = "0\nCIRCLE\n8\nW\n10\n3\n20\n0\n40\n0.5\n210\n0\n220\n0\n230\n-1\n";
        let paper = "0\nLINE\n67\n1\n8\nW\n10\n0\n20\n0\n11\n100\n21\n0\n";
        let hatch = "0\nHATCH\n8\nW\n10\nnot even a number\n";
        let f =
            import(&drawing(Some(6), "", &[room(2.0, 2.0, 1.0), circle.into(), paper.into(), hatch.into()].concat()))
                .unwrap();
        assert_eq!(at(&f, -2.5, 0.0), Cell::Occupied);
        let [x0, y0, x1, y1] = f.report.extent_m;
        let near = |a: f64, b: f64| (a - b).abs() < 0.0125;
        assert!(near(x0, -3.5) && near(y0, -0.5) && x1 == 2.0 && y1 == 2.0, "{:?}", f.report.extent_m);
        assert_eq!(f.report.skipped, BTreeMap::from([("(paper space)".into(), 1), ("HATCH".into(), 1)]));
    }

    #[test]
    fn what_is_not_read_is_counted_where_it_is_drawn() {
        // a block with a hatch, inserted twice; a dimension's block, never inserted
        let blocks = "0\nBLOCK\n2\nHATCHED\n0\nHATCH\n8\n0\n0\nLINE\n11\n1\n0\nENDBLK\n\
                      0\nBLOCK\n2\n*D1\n0\nSOLID\n0\nPOINT\n0\nENDBLK\n";
        let inserts = "0\nINSERT\n2\nHATCHED\n10\n1\n20\n1\n0\nINSERT\n2\nhatched\n10\n2\n20\n2\n\
                       0\nDIMENSION\n2\n*D1\n";
        let f = import(&drawing(Some(6), blocks, &[room(4.0, 3.0, 1.0).as_str(), inserts].concat())).unwrap();
        assert_eq!(f.report.skipped, BTreeMap::from([("DIMENSION".into(), 1), ("HATCH".into(), 2)]));
        assert_eq!(f.report.wall_entities, 6);
    }

    #[test]
    fn malformed_or_unusable_drawings_are_refused_with_file_and_line() {
        let good = drawing(Some(6), "", &room(4.0, 3.0, 1.0));
        let self_insert = "0\nBLOCK\n2\nloop\n0\nINSERT\n2\nloop\n0\nLINE\n11\n1\n0\nENDBLK\n";
        let cases: Vec<(String, &str)> = vec![
            (String::new(), "plan.dxf:1: malformed DXF: the file is empty"),
            ("hello\nworld\n".into(), "plan.dxf:1: malformed DXF: group code \"hello\" is not an integer"),
            ("AutoCAD Binary DXF\r\n\x1a\0".into(), "plan.dxf:1: binary DXF is not read"),
            ("0\nLINE\n".into(), "plan.dxf:2: malformed DXF: expected 0/SECTION or 0/EOF, found 0/\"LINE\""),
            (
                good.replacen("20\n0\n", "20\nzero\n", 1),
                "plan.dxf:32: malformed DXF: group code 20: \"zero\" is not a number",
            ),
            (
                good.replacen("20\n0\n", "20\n1e300\n", 1),
                "plan.dxf:32: malformed DXF: group code 20: \"1e300\" is out of range",
            ),
            (good.replace("0\nEOF\n", ""), "malformed DXF: no 0/EOF at the end"),
            (good[..good.len() - 40].to_string(), "the file ends inside the ENTITIES section that starts here"),
            (good.replacen("11\n4\n", "11\n", 1), "plan.dxf:39: malformed DXF: group code \"0.0\" is not an integer"),
            (good.replace("0\nENDSEC\n0\nEOF", "0\nEOF"), "0/EOF inside the ENTITIES section"),
            (drawing(None, "", &room(4.0, 3.0, 1.0)), "plan.dxf: the drawing has no units"),
            (drawing(Some(3), "", &room(4.0, 3.0, 1.0)), "plan.dxf:12: $INSUNITS 3 is not a unit"),
            (drawing(Some(6), "", ""), "plan.dxf: no walls"),
            (drawing(Some(6), "", &text("T", "lonely", [0.0, 0.0])), "plan.dxf: no walls"),
            (drawing(Some(6), "", &room(4.0, 3000.0, 1.0)), "spans 4 x 3000 m read in m, more than the 2000 m"),
            (drawing(Some(6), self_insert, "0\nINSERT\n2\nLOOP\n"), "blocks nested more than 16 deep"),
            ("0\nSECTION\n2\nHEADER\n0\nENDSEC\n0\nEOF\n".into(), "plan.dxf: no ENTITIES section"),
        ];
        for (text, expected) in cases {
            let e = import(&text).expect_err(expected).to_string();
            assert!(e.starts_with(expected) || e.contains(expected), "expected {expected:?} in: {e}");
            assert!(e.contains("plan.dxf"), "{e}");
        }
        for (options, why) in [
            (DxfImport { resolution_m: 0.0, ..DxfImport::default() }, "resolution 0"),
            (DxfImport { wall_thickness_m: -1.0, ..DxfImport::default() }, "wall thickness -1 m is absurd"),
            (DxfImport { margin_m: f64::NAN, ..DxfImport::default() }, "margin NaN m is absurd"),
            (DxfImport { resolution_m: 1e-6, ..DxfImport::default() }, "cells is more than the limit"),
        ] {
            let e = options.parse(good.as_bytes(), Path::new("plan.dxf")).unwrap_err().to_string();
            assert!(e.contains(why) && e.contains("plan.dxf"), "expected {why:?} in: {e}");
        }
    }

    #[test]
    fn windows_1252_text_and_crlf_lines_are_read() {
        let text = drawing(Some(6), "", &[room(4.0, 3.0, 1.0), text("T", "caf\u{e9} \u{20ac}", [1.0, 1.0])].concat());
        let crlf = text.replace('\n', "\r\n");
        let bytes: Vec<u8> = crlf
            .chars()
            .map(|c| match c {
                '\u{e9}' => 0xe9,
                '\u{20ac}' => 0x80,
                c => c as u8,
            })
            .collect();
        let f = DxfImport::default().parse(&bytes, Path::new("ansi.dxf")).unwrap();
        assert_eq!(f.semantic.labels[0].name, "café €");
        assert_eq!(f.grid, import(&text).unwrap().grid);
    }

    #[test]
    fn units_parse_from_their_names() {
        for (s, u) in [
            ("mm", Units::Millimetres),
            ("CM", Units::Centimetres),
            ("m", Units::Metres),
            ("in", Units::Inches),
            ("feet", Units::Feet),
        ] {
            assert_eq!(s.parse::<Units>(), Ok(u));
            assert_eq!(u.symbol().parse::<Units>(), Ok(u));
            assert_eq!(
                Units::from_insunits(match u {
                    Units::Inches => 1,
                    Units::Feet => 2,
                    Units::Millimetres => 4,
                    Units::Centimetres => 5,
                    Units::Metres => 6,
                }),
                Some(u)
            );
        }
        assert!("yards".parse::<Units>().unwrap_err().contains("mm, cm, m, in or ft"));
        assert_eq!(Units::from_insunits(0), None);
    }
}
