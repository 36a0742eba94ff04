//! Property tests of every decoder of outside files in the map crate: map_server YAML
//! (`parse_map_yaml`), PGM (`decode_pgm`: P5 8 and 16 bit, P2), PNG (`decode_png`), a
//! whole map from disk (`load_map`: YAML + image), the semantic layer
//! (`SemanticLayer::parse`), the building manifest (`Building::load`) and CAD floor
//! plans (`DxfImport::parse`). Mutated valid files and random bytes must give a value
//! or a [`MapError`] naming the file (and the line where the parser has one): never a
//! panic, never an allocation beyond the size limits, never a hang.
//!
//! Seeds: the TurtleBot3 map as ROS map_saver wrote it (`tests/data/map.{yaml,pgm}`),
//! the office floor ezdxf wrote (`tests/data/floor.dxf`), plus small files made here
//! (PGMs of every kind, PNGs of every colour type, YAML in every mode, semantic layers,
//! manifests, DXF drawings of every entity read). CI runs a bounded number of cases (`CASES`,
//! see `docs/fuzzing.md`); `wearnav fuzz` runs millions on demand. `PROPTEST_CASES=N`
//! sets the cases per property.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::LazyLock;
use std::time::Duration;

use decoder_props::{config, measured, mutated, mutation_with, within, LargestAllocation};
use map::dxf::{DxfImport, MAX_EXTENT_M};
use map::map_server::{decode_png, parse_map_yaml, MAX_DEFLATE_RATIO};
use map::pgm::decode_pgm;
use map::{load_map, Building, Cell, MapError, SemanticLayer, MAX_CELLS};
use proptest::prelude::*;
use proptest::sample::Index;

#[global_allocator]
static ALLOCATOR: LargestAllocation = LargestAllocation;

/// Text that header, YAML and TOML parsers meet with edge cases.
static TOKENS: [&str; 20] = [
    "4294967295",
    "18446744073709551615",
    "99999999999999999999",
    "-1",
    "0",
    "nan",
    ".nan",
    "inf",
    "-1e400",
    "1e308",
    "\n",
    " ",
    "\"",
    "[",
    "]]",
    "=",
    "&a [*a, *a]",
    "\t- ",
    "# ",
    "\nP2 ",
];

/// Text a DXF reader meets with edge cases: structure tags, entities, huge counts and
/// coordinates, bulges, nesting.
static DXF_TOKENS: [&str; 16] = [
    "  0\nSECTION\n",
    "  0\nENDSEC\n",
    "  0\nEOF\n",
    "  0\nINSERT\n  2\nCOLUMN\n",
    "  0\nSEQEND\n",
    "\n 42\n1e9\n",
    "\n 70\n32767\n 71\n32767\n",
    "\n 40\n1e11\n",
    "\n 41\n-1e11\n",
    "\n210\n0\n220\n1\n230\n0\n",
    "1e300",
    "nan",
    "-0",
    "\\P{\\f",
    "%%",
    "\\U+",
];

/// Cases per property in CI (measured numbers in `docs/fuzzing.md`).
const CASES: u32 = 50_000;

// ---------------------------------------------------------------------------------
// Seeds.

/// ROS map_saver's output for the TurtleBot3 world (see `tests/data/README.md`).
const ROS_YAML: &str = include_str!("data/map.yaml");
const ROS_PGM: &[u8] = include_bytes!("data/map.pgm");

fn yaml_seeds() -> Vec<Vec<u8>> {
    [
        ROS_YAML,
        "image: m.png\nmode: raw\nresolution: 0.1\norigin: [0.5, -2.25, 1.5707963]\nnegate: true\n\
         occupied_thresh: 0.9\nfree_thresh: 0.1\n",
        "# a comment\nimage: \"floor 2/map.pgm\"\nresolution: 5e-2\norigin:\n  - -1.0\n  - 2\n  - 0\n\
         negate: 1\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: scale\n",
        "{image: m.pgm, resolution: 1, origin: [0, 0, 0], negate: 0, occupied_thresh: 1, free_thresh: 0}\n",
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect()
}

/// The ROS map, and small PGMs of every kind: P5 8 bit, P5 16 bit, P5 with an odd
/// maxval, P2 with comments.
fn pgm_seeds() -> Vec<Vec<u8>> {
    let mut p5 = b"P5\n# CREATOR: map_saver.cpp 0.050 m/pix\n6 4\n255\n".to_vec();
    p5.extend((0..24u8).map(|i| [254, 0, 205][i as usize % 3]));
    let mut p5_16 = b"P5 3 2 65535\n".to_vec();
    p5_16.extend([0u16, 65535, 1000, 40000, 205 * 257, 7].iter().flat_map(|v| v.to_be_bytes()));
    let mut p5_15 = b"P5\n2 3\n15\n".to_vec();
    p5_15.extend([0, 15, 7, 3, 15, 0]);
    let p2 = b"P2\n# a comment\n4 3 # trailing\n# another\n255\n254 0 205 254\n 0 0 254\n205 254 254 0 1\n".to_vec();
    let p2_16 = b"P2 2 2 65535 0 65535 300 40000\n".to_vec();
    vec![ROS_PGM.to_vec(), p5, p5_16, p5_15, p2, p2_16]
}

fn png_bytes(width: u32, height: u32, color: png::ColorType, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(color);
    encoder.set_depth(depth);
    if color == png::ColorType::Indexed {
        encoder.set_palette(vec![0, 0, 0, 254, 254, 254, 205, 205, 205, 10, 200, 30]);
    }
    let mut writer = encoder.write_header().expect("PNG header writes");
    writer.write_image_data(data).expect("PNG data writes");
    writer.finish().expect("PNG ends");
    out
}

/// PNGs of every colour type the loader reads: grey 1, 8 and 16 bit, grey + alpha, RGB,
/// RGBA, a palette.
fn png_seeds() -> Vec<Vec<u8>> {
    use png::{BitDepth::*, ColorType::*};
    let grey: Vec<u8> = (0..30u8).map(|i| [254, 0, 205][i as usize % 3]).collect();
    let grey16: Vec<u8> = (0..30u16).flat_map(|i| (i * 2000).to_be_bytes()).collect();
    let ga: Vec<u8> = (0..30u8).flat_map(|i| [i * 8, 255 - i]).collect();
    let rgb: Vec<u8> = (0..30u8).flat_map(|i| [i * 8, 254, 0]).collect();
    let rgba: Vec<u8> = (0..30u8).flat_map(|i| [i * 8, 254, 0, 128]).collect();
    vec![
        png_bytes(6, 5, Grayscale, Eight, &grey),
        png_bytes(6, 5, Grayscale, Sixteen, &grey16),
        png_bytes(16, 2, Grayscale, One, &[0b1010_0000, 0xff, 0x0f, 0x00]),
        png_bytes(6, 5, GrayscaleAlpha, Eight, &ga),
        png_bytes(6, 5, Rgb, Eight, &rgb),
        png_bytes(6, 5, Rgba, Eight, &rgba),
        png_bytes(4, 2, Indexed, Eight, &[0, 1, 2, 3, 3, 2, 1, 0]),
    ]
}

/// The layer of the module's documentation, and smaller ones.
fn semantic_seeds() -> Vec<Vec<u8>> {
    [
        include_str!("data/sample.semantic.toml"),
        "label = [{ name = \"toilets\", x = 1, y = 2.5, floor = 0 }]\n\
         corner = [{ x = -3.0, y = 4e1, floor = 0 }]\n",
        "[[gateway]]\nname = \"stairs A\"\ntype = \"stairs\"\n\
         stops = [{ floor = -1, x = 0.0, y = 0.0 }, { floor = 0, x = 0.5, y = 0.0 }, { floor = 1, x = 1.0, y = 0.0 }]\n\
         [[door]]\nnumber = 'B1.07'\nx = 1.0\ny = 1.0\nfloor = -1\nnormal = [1e-3, -1e-3]\n",
        "",
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect()
}

/// Manifests of the two-floor building written in each case's folder.
fn manifest_seeds() -> Vec<Vec<u8>> {
    [
        "[[floor]]\nlevel = 0\nmap = \"floor0.yaml\"\nsemantic = \"floor0.toml\"\n\n\
         [[floor]]\nlevel = 1\nmap = \"floor1.yaml\"\nsemantic = \"floor1.toml\"\n",
        "floor = [{ level = 1, map = \"floor1.yaml\" }]\n",
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect()
}

/// The office floor ezdxf wrote (R2013, millimetres, see `tests/data/make_floor_dxf.py`).
const FLOOR_DXF: &[u8] = include_bytes!("data/floor.dxf");

/// The ezdxf floor and small drawings made here: R12-style POLYLINE with VERTEX and
/// SEQEND, nested and arrayed INSERTs, a mirrored OCS, MTEXT chunks, TEXT justified.
fn dxf_seeds() -> Vec<Vec<u8>> {
    let drawing = |insunits: u8, blocks: &str, entities: &str| {
        format!(
            "  0\nSECTION\n  2\nHEADER\n  9\n$INSUNITS\n 70\n{insunits}\n  0\nENDSEC\n\
             0\nSECTION\n2\nBLOCKS\n{blocks}0\nENDSEC\n0\nSECTION\n2\nENTITIES\n{entities}0\nENDSEC\n0\nEOF\n"
        )
        .into_bytes()
    };
    let polyline = "0\nPOLYLINE\n8\nW\n66\n1\n70\n1\n0\nVERTEX\n10\n0\n20\n0\n\
                    0\nVERTEX\n10\n4\n20\n4\n42\n-1\n0\nVERTEX\n10\n4\n20\n0\n0\nSEQEND\n\
                    0\nTEXT\n8\nT\n10\n1\n20\n1\n11\n2\n21\n2\n72\n1\n73\n2\n1\nroom %%d1\n";
    let blocks = "0\nBLOCK\n2\nCOLUMN\n10\n0\n20\n0\n0\nCIRCLE\n8\n0\n10\n0\n20\n0\n40\n150\n0\nENDBLK\n\
                  0\nBLOCK\n2\nPAIR\n10\n0\n20\n0\n0\nINSERT\n2\nCOLUMN\n10\n0\n20\n0\n\
                  0\nINSERT\n2\nCOLUMN\n10\n1000\n20\n0\n41\n-1\n0\nENDBLK\n";
    let inserts = "0\nLWPOLYLINE\n8\nWALLS\n90\n4\n70\n1\n10\n0\n20\n0\n10\n8000\n20\n0\n42\n0.4\n\
                   10\n8000\n20\n6000\n10\n0\n20\n6000\n\
                   0\nINSERT\n8\nWALLS\n2\nPAIR\n10\n2000\n20\n3000\n50\n30\n70\n3\n71\n2\n44\n1500\n45\n1500\n\
                   0\nARC\n8\nW\n10\n4000\n20\n3000\n40\n500\n50\n10\n51\n300\n210\n0\n220\n0\n230\n-1\n\
                   0\nMTEXT\n8\nT\n10\n4000\n20\n1000\n71\n5\n3\n{\\fArial|b1;hall \n1\nwest}\\Pdoor\n";
    vec![FLOOR_DXF.to_vec(), drawing(6, "", polyline), drawing(4, blocks, inserts)]
}

/// Seeds are made once: making them took most of a case's time.
static YAML_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(yaml_seeds);
static PGM_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(pgm_seeds);
static PNG_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(png_seeds);
static SEMANTIC_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(semantic_seeds);
static MANIFEST_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(manifest_seeds);
static DXF_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(dxf_seeds);
/// Small images for whole maps on disk (the ROS map's 147 KB would be most of the time).
static IMAGE_SEEDS: LazyLock<Vec<Vec<u8>>> =
    LazyLock::new(|| PGM_SEEDS[1..].iter().chain(PNG_SEEDS.iter()).cloned().collect());

// ---------------------------------------------------------------------------------
// Checks: a value that keeps its contract, or a MapError naming the file and a line in it.

/// The error names `file` and, where the parser has a line, one within the text.
fn check_error(e: &MapError, file: &Path, bytes: &[u8]) -> Result<(), String> {
    let text = e.to_string();
    if !text.contains(&file.display().to_string()) {
        return Err(format!("error does not name {}: {text}", file.display()));
    }
    let lines = bytes.iter().filter(|&&b| b == b'\n' || b == b'\r').count() + 1;
    let line = match e {
        MapError::Pgm { line, .. } | MapError::Semantic { line, .. } | MapError::Building { line, .. } => Some(*line),
        MapError::Yaml { line, .. } | MapError::Dxf { line, .. } => Some(*line),
        _ => None,
    };
    match line {
        Some(line) if line > lines => Err(format!("line {line} of a {lines}-line file: {text}")),
        _ => Ok(()),
    }
}

/// Largest single allocation a PGM decode may make: the pixels, once the file is known
/// to hold them (a byte per P5 pixel or two per P2 value), so about the file's size.
fn pgm_bound(len: usize) -> usize {
    2 * len + 64 * 1024
}

fn check_pgm(bytes: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz.pgm");
    let (result, largest, took) = measured(|| decode_pgm(bytes, file));
    within("PGM", largest, pgm_bound(bytes.len()), took)?;
    match result {
        Ok(img) if img.pixels.len() != img.width * img.height || !img.alpha.is_empty() => {
            Err(format!("{}x{} PGM of {} pixels", img.width, img.height, img.pixels.len()))
        }
        Ok(img) if (img.width * img.height) as u64 > MAX_CELLS => Err(format!("{}x{} PGM", img.width, img.height)),
        Ok(_) => Ok(()),
        Err(e) => check_error(&e, file, bytes),
    }
}

/// Largest single allocation a PNG decode may make: the expanded image (at most 4
/// bytes a cell, `MAX_CELLS` cells; 32 bytes per byte of 1-bit palette rows, which a
/// file holds at most `MAX_DEFLATE_RATIO` of per byte) and the decoder's buffers.
fn png_bound(len: usize) -> usize {
    (4 * MAX_CELLS as usize).min(32 * MAX_DEFLATE_RATIO as usize * len) + (1 << 20)
}

fn check_png(bytes: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz.png");
    let (result, largest, took) = measured(|| decode_png(bytes, file));
    within("PNG", largest, png_bound(bytes.len()), took)?;
    match result {
        Ok(img)
            if img.pixels.len() != img.width * img.height
                || !(img.alpha.is_empty() || img.alpha.len() == img.pixels.len()) =>
        {
            Err(format!("{}x{} PNG of {} pixels, {} alpha", img.width, img.height, img.pixels.len(), img.alpha.len()))
        }
        Ok(_) => Ok(()),
        Err(e) => check_error(&e, file, bytes),
    }
}

/// Largest single allocation a YAML or TOML parse may make: its tables and strings come
/// from the text (the TOML parser keeps an event of about 48 bytes per token).
fn text_bound(len: usize) -> usize {
    64 * len + 256 * 1024
}

fn check_yaml(bytes: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz.yaml");
    let text = String::from_utf8_lossy(bytes);
    let (result, largest, took) = measured(|| parse_map_yaml(&text, file));
    within("map YAML", largest, text_bound(text.len()), took)?;
    match result {
        Ok(m) => {
            let sane = m.resolution_m > 0.0
                && m.resolution_m <= map::MAX_RESOLUTION_M
                && 0.0 <= m.free_thresh
                && m.free_thresh < m.occupied_thresh
                && m.occupied_thresh <= 1.0
                && [m.origin.x_m, m.origin.y_m, m.origin.yaw_rad].iter().all(|v| v.is_finite())
                && !m.image.as_os_str().is_empty();
            if sane {
                Ok(())
            } else {
                Err(format!("accepted {m:?}"))
            }
        }
        Err(e) => check_error(&e, file, text.as_bytes()),
    }
}

fn check_semantic(bytes: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz.toml");
    let text = String::from_utf8_lossy(bytes);
    let (result, largest, took) = measured(|| SemanticLayer::parse(&text, file));
    within("semantic", largest, text_bound(text.len()), took)?;
    match result {
        Ok(layer) => {
            let unit = layer.doors.iter().all(|d| (d.normal[0].hypot(d.normal[1]) - 1.0).abs() < 1e-9);
            let stops = layer.gateways.iter().all(|g| g.stops.len() >= 2);
            let polygons = layer.areas.iter().all(|a| a.polygon.len() >= 3);
            if !(unit && stops && polygons) {
                return Err(format!("accepted {layer:?}"));
            }
            // what was accepted writes out and reads back the same (door normals are
            // normalised again on reading, which may move their last bit)
            let without_normals = |mut l: SemanticLayer| {
                l.doors.iter_mut().for_each(|d| d.normal = [0.0; 2]);
                l
            };
            match SemanticLayer::parse(&layer.to_toml(), file) {
                Ok(again)
                    if again.doors.iter().zip(&layer.doors).all(|(a, b)| {
                        (a.normal[0] - b.normal[0]).abs() < 1e-12 && (a.normal[1] - b.normal[1]).abs() < 1e-12
                    }) && without_normals(again.clone()) == without_normals(layer.clone()) =>
                {
                    Ok(())
                }
                other => Err(format!("{layer:?} reads back as {other:?}")),
            }
        }
        Err(e) => check_error(&e, file, text.as_bytes()),
    }
}

/// The import the DXF cases run: 10 cm cells (a quarter of the default's cells, the
/// same code), the other options at their defaults.
fn dxf_import() -> DxfImport {
    DxfImport { resolution_m: 0.1, ..DxfImport::default() }
}

/// Largest single allocation a DXF import may make: the text (Windows-1252 decoded to
/// UTF-8 is at most 3 bytes a byte), the entities read (each at least 7 bytes of text),
/// and the grid, which is checked against `MAX_CELLS` first (a byte a cell).
fn dxf_bound(len: usize) -> usize {
    text_bound(len).max(MAX_CELLS as usize)
}

fn check_dxf(bytes: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz.dxf");
    let (result, largest, took) = measured(|| dxf_import().parse(bytes, file));
    within("DXF", largest, dxf_bound(bytes.len()), took)?;
    match result {
        Ok(floor) => {
            let g = &floor.grid;
            let [x0, y0, x1, y1] = floor.report.extent_m;
            let sane = g.cells().len() == g.width() * g.height()
                && g.count(Cell::Occupied) > 0
                && (x1 - x0) <= MAX_EXTENT_M
                && (y1 - y0) <= MAX_EXTENT_M
                && floor.semantic.labels.iter().all(|l| {
                    !l.name.trim().is_empty()
                        && l.x.is_finite()
                        && l.y.is_finite()
                        && g.world_to_cell(l.x, l.y).is_some()
                });
            if !sane {
                return Err(format!("accepted {}x{} grid, report {:?}", g.width(), g.height(), floor.report));
            }
            // what was accepted writes out as a semantic layer that reads back the same
            match SemanticLayer::parse(&floor.semantic.to_toml(), file) {
                Ok(again) if again == floor.semantic => Ok(()),
                other => Err(format!("{:?} reads back as {other:?}", floor.semantic)),
            }
        }
        Err(e) => check_error(&e, file, bytes),
    }
}

// ---------------------------------------------------------------------------------
// Files on disk: `load_map` and `Building::load` read a folder.

/// A fresh folder per case under the system's temp folder, removed on drop.
struct CaseDir(PathBuf);

impl CaseDir {
    fn new() -> CaseDir {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("map-decoders-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp folder");
        CaseDir(dir)
    }

    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, bytes).expect("temp file");
        path
    }
}

impl Drop for CaseDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A map YAML naming `image`, with the ROS file's other fields.
fn yaml_for(image: &str) -> String {
    ROS_YAML.replace("map.pgm", image)
}

/// Loads a (mutated) YAML naming a (mutated) image: the bound is the larger of the two
/// readers' bounds.
fn check_load_map(yaml: &[u8], image_name: &str, image: &[u8]) -> Result<(), String> {
    let dir = CaseDir::new();
    let yaml_path = dir.write("map.yaml", yaml);
    dir.write(image_name, image);
    let (result, largest, took) = measured(|| load_map(&yaml_path));
    let bound = text_bound(yaml.len()).max(png_bound(image.len())).max(pgm_bound(image.len()));
    within("load_map", largest, bound, took)?;
    match result {
        Ok(grid) if grid.cells().len() != grid.width() * grid.height() => {
            Err(format!("{}x{} grid of {} cells", grid.width(), grid.height(), grid.cells().len()))
        }
        Ok(_) => Ok(()),
        // the YAML's errors name the YAML, the image's the image; a file the (mutated)
        // YAML names but that is not there, or of another kind, is named as written
        Err(MapError::Io { .. } | MapError::UnknownImageFormat { .. }) => Ok(()),
        Err(e) => {
            let file = error_file(&e);
            if file == yaml_path || file == dir.0.join(image_name) {
                Ok(())
            } else {
                Err(format!("error names {}: {e}", file.display()))
            }
        }
    }
}

/// The file an error names (every kind names one).
fn error_file(e: &MapError) -> &Path {
    match e {
        MapError::Io { file, .. }
        | MapError::FileTooLarge { file, .. }
        | MapError::Yaml { file, .. }
        | MapError::BadField { file, .. }
        | MapError::Thresholds { file, .. }
        | MapError::Resolution { file, .. }
        | MapError::UnknownImageFormat { file, .. }
        | MapError::Pgm { file, .. }
        | MapError::Png { file, .. }
        | MapError::Empty { file, .. }
        | MapError::TooLarge { file, .. }
        | MapError::SizeMismatch { file, .. }
        | MapError::Semantic { file, .. }
        | MapError::Building { file, .. }
        | MapError::Dxf { file, .. } => file,
    }
}

/// Loads a (mutated) manifest over two valid floors written beside it.
fn check_building(manifest: &[u8]) -> Result<(), String> {
    let dir = CaseDir::new();
    for (level, semantic) in [(0, "corner = [{ x = 1.0, y = 1.0, floor = 0 }]\n"), (1, "")] {
        dir.write(&format!("floor{level}.yaml"), yaml_for(&format!("floor{level}.pgm")).as_bytes());
        dir.write(&format!("floor{level}.pgm"), &PGM_SEEDS[1]);
        dir.write(&format!("floor{level}.toml"), semantic.as_bytes());
    }
    let path = dir.write("building.toml", manifest);
    let (result, largest, took) = measured(|| Building::load(&path));
    within("building", largest, text_bound(manifest.len()), took)?;
    match result {
        Ok(b) if b.floors().is_empty() || b.floors().windows(2).any(|w| w[0].level >= w[1].level) => {
            Err(format!("accepted floors {:?}", b.floors().iter().map(|f| f.level).collect::<Vec<_>>()))
        }
        Ok(_) => Ok(()),
        Err(MapError::Building { line, .. }) if line > manifest.len() + 1 => Err(format!("line {line}")),
        Err(e) if e.to_string().is_empty() => Err("an error that says nothing".into()),
        Err(_) => Ok(()),
    }
}

#[test]
fn every_seed_is_valid() {
    for (i, s) in yaml_seeds().iter().enumerate() {
        parse_map_yaml(std::str::from_utf8(s).expect("UTF-8"), Path::new("seed.yaml"))
            .unwrap_or_else(|e| panic!("YAML seed {i}: {e}"));
    }
    for (i, s) in pgm_seeds().iter().enumerate() {
        decode_pgm(s, Path::new("seed.pgm")).unwrap_or_else(|e| panic!("PGM seed {i}: {e}"));
    }
    for (i, s) in png_seeds().iter().enumerate() {
        decode_png(s, Path::new("seed.png")).unwrap_or_else(|e| panic!("PNG seed {i}: {e}"));
    }
    for (i, s) in semantic_seeds().iter().enumerate() {
        SemanticLayer::parse(std::str::from_utf8(s).expect("UTF-8"), Path::new("seed.toml"))
            .unwrap_or_else(|e| panic!("semantic seed {i}: {e}"));
    }
    for (i, s) in manifest_seeds().iter().enumerate() {
        assert_eq!(check_building(s), Ok(()), "manifest seed {i}");
    }
    for (i, s) in dxf_seeds().iter().enumerate() {
        let floor = dxf_import().parse(s, Path::new("seed.dxf")).unwrap_or_else(|e| panic!("DXF seed {i}: {e}"));
        assert!(floor.report.skipped.is_empty() || i == 0, "DXF seed {i}: {:?}", floor.report.skipped);
        assert_eq!(check_dxf(s), Ok(()), "DXF seed {i}");
    }
    for (i, s) in manifest_seeds().iter().enumerate() {
        let dir = CaseDir::new();
        dir.write("floor0.yaml", yaml_for("floor0.pgm").as_bytes());
        dir.write("floor1.yaml", yaml_for("floor1.png").as_bytes());
        dir.write("floor0.pgm", &PGM_SEEDS[2]);
        dir.write("floor1.png", &PNG_SEEDS[0]);
        dir.write("floor0.toml", b"");
        dir.write("floor1.toml", b"label = [{ name = \"hall\", x = 0.0, y = 0.0, floor = 1 }]\n");
        Building::load(&dir.write("b.toml", s)).unwrap_or_else(|e| panic!("manifest seed {i}: {e}"));
    }
    let dir = CaseDir::new();
    dir.write("map.pgm", ROS_PGM);
    let grid = load_map(&dir.write("map.yaml", ROS_YAML.as_bytes())).expect("the ROS map loads");
    assert_eq!((grid.width(), grid.height()), (384, 384));
}

proptest! {
    #![proptest_config(config(CASES))]

    #[test]
    fn mutated_map_yaml_parses_or_is_refused_with_its_line(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&TOKENS), 1..6),
    ) {
        let outcome = check_yaml(&mutated(&YAML_SEEDS, &seed, &mutations));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn mutated_pgms_decode_to_their_size_or_are_refused(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&TOKENS), 1..6),
    ) {
        let outcome = check_pgm(&mutated(&PGM_SEEDS, &seed, &mutations));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn mutated_pngs_decode_to_their_size_or_are_refused(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&TOKENS), 1..6),
    ) {
        let outcome = check_png(&mutated(&PNG_SEEDS, &seed, &mutations));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn mutated_dxf_drawings_import_or_are_refused_with_their_line(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&DXF_TOKENS), 1..6),
    ) {
        let outcome = check_dxf(&mutated(&DXF_SEEDS, &seed, &mutations));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn mutated_semantic_layers_parse_and_read_back_or_are_refused(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&TOKENS), 1..6),
    ) {
        let outcome = check_semantic(&mutated(&SEMANTIC_SEEDS, &seed, &mutations));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }
}

proptest! {
    // Files on disk cost a folder per case, and random bytes rarely get past the
    // first byte of any format: fewer cases.
    #![proptest_config(config(CASES / 20))]

    #[test]
    fn mutated_maps_on_disk_load_or_are_refused_naming_the_file(
        yaml_seed in any::<Index>(),
        image_seed in any::<Index>(),
        yaml_mutations in prop::collection::vec(mutation_with(&TOKENS), 0..3),
        image_mutations in prop::collection::vec(mutation_with(&TOKENS), 0..4),
    ) {
        let image = mutated(&IMAGE_SEEDS, &image_seed, &image_mutations);
        let name = if image.starts_with(b"P") { "map.pgm" } else { "map.png" };
        let yaml = mutated(&[yaml_for(name).into_bytes()], &yaml_seed, &yaml_mutations);
        let outcome = check_load_map(&yaml, name, &image);
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn mutated_building_manifests_load_or_are_refused(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&TOKENS), 1..6),
    ) {
        let outcome = check_building(&mutated(&MANIFEST_SEEDS, &seed, &mutations));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn random_bytes_are_refused_by_every_reader(bytes in prop::collection::vec(any::<u8>(), 0..1024)) {
        for outcome in [check_yaml(&bytes), check_pgm(&bytes), check_png(&bytes), check_semantic(&bytes), check_dxf(&bytes)] {
            prop_assert!(outcome.is_ok(), "{:?}", outcome);
        }
    }
}

// ---------------------------------------------------------------------------------
// Forged sizes and hostile text: refused before allocating, without a stack overflow.

#[test]
fn pgm_headers_declaring_huge_images_are_refused_before_allocating() {
    for header in ["P5 8192 8192 255\n", "P5\n4096 16384\n65535\n", "P2 8192 8192 255\n", "P2 1 67108864 7 "] {
        let bytes = format!("{header}0 1 2 3 4 5 6 7");
        let (result, largest, _) = measured(|| decode_pgm(bytes.as_bytes(), Path::new("forged.pgm")));
        assert!(matches!(result, Err(MapError::SizeMismatch { .. })), "{header:?}: {result:?}");
        assert!(largest < 4096, "{header:?}: allocated {largest} bytes at once");
    }
    for size in ["100000 100000", "18446744073709551615 18446744073709551615", "4294967296 4294967296"] {
        let bytes = format!("P5 {size} 255\n\0");
        let (result, largest, _) = measured(|| decode_pgm(bytes.as_bytes(), Path::new("huge.pgm")));
        assert!(matches!(result, Err(MapError::TooLarge { .. })), "{size}: {result:?}");
        assert!(largest < 4096, "{size}: allocated {largest} bytes at once");
    }
}

/// A PNG's IHDR claiming `width` x `height` RGBA pixels (8 bit), with a valid CRC and
/// the seed's few bytes of image data.
fn forged_png(width: u32, height: u32) -> Vec<u8> {
    let mut png = png_seeds().swap_remove(5);
    png[16..20].copy_from_slice(&width.to_be_bytes());
    png[20..24].copy_from_slice(&height.to_be_bytes());
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    png
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 { crc >> 1 ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

#[test]
fn pngs_declaring_huge_images_are_refused_before_allocating() {
    for (w, h) in [(8192, 8192), (1, 1 << 26), (1 << 20, 1 << 20), (0x7fff_ffff, 0x7fff_ffff), (2000, 2000)] {
        let png = forged_png(w, h);
        let (result, largest, _) = measured(|| decode_png(&png, Path::new("forged.png")));
        assert!(matches!(result, Err(MapError::Png { .. } | MapError::TooLarge { .. })), "{w}x{h}: {result:?}");
        assert!(largest < 1 << 20, "{w}x{h}: allocated {largest} bytes at once");
    }
}

#[test]
fn yaml_alias_bombs_and_deep_nesting_are_refused_not_a_stack_overflow() {
    let mut bomb = String::from("a: &a [x, x, x, x, x, x, x, x, x, x]\n");
    for i in 0..12 {
        let prev = if i == 0 { "a".to_string() } else { format!("b{}", i - 1) };
        bomb.push_str(&format!("b{i}: &b{i} [*{prev}, *{prev}, *{prev}, *{prev}, *{prev}, *{prev}, *{prev}]\n"));
    }
    bomb.push_str("image: m.pgm\n");
    // 100,000 nested `{a: ` took the YAML parser 29 s (its time grows with the square
    // of the depth): refused by depth first, at once
    let deep = ["image: [", "origin: {a: ", "[a, "].map(|open| open.repeat(100_000));
    for text in [bomb].iter().chain(&deep) {
        assert_eq!(check_yaml(text.as_bytes()), Ok(()), "{}", &text[..40]);
        assert!(parse_map_yaml(text, Path::new("bomb.yaml")).is_err());
    }
    let (_, _, took) = measured(|| parse_map_yaml(&deep[1], Path::new("deep.yaml")));
    assert!(took < Duration::from_millis(100), "took {took:?}");
    let nested = format!("{}{}", "[".repeat(map::map_server::MAX_YAML_NESTING), "]".repeat(64));
    let text = ROS_YAML.replace("map.pgm", &format!("\"m{nested}.pgm\""));
    assert!(parse_map_yaml(&text, Path::new("ok.yaml")).is_ok(), "{text}");
    for text in [format!("label = {}", "[".repeat(100_000)), format!("label = {}", "{a=".repeat(100_000))] {
        assert_eq!(check_semantic(text.as_bytes()), Ok(()));
    }
}

#[test]
fn dxf_block_bombs_huge_arrays_and_huge_extents_are_refused_before_allocating() {
    let drawing = |blocks: &str, entities: &str| {
        format!(
            "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n6\n0\nENDSEC\n0\nSECTION\n2\nBLOCKS\n{blocks}0\nENDSEC\n\
             0\nSECTION\n2\nENTITIES\n{entities}0\nENDSEC\n0\nEOF\n"
        )
    };
    // ten levels of blocks, each inserting the one below ten times: 10^10 lines
    let mut blocks = "0\nBLOCK\n2\nB0\n0\nLINE\n10\n0\n20\n0\n11\n1\n21\n0\n0\nENDBLK\n".to_string();
    for level in 1..10 {
        blocks.push_str(&format!("0\nBLOCK\n2\nB{level}\n"));
        for k in 0..10 {
            blocks.push_str(&format!("0\nINSERT\n2\nB{}\n10\n{k}\n20\n0\n41\n0.1\n", level - 1));
        }
        blocks.push_str("0\nENDBLK\n");
    }
    let bomb = drawing(&blocks, "0\nINSERT\n2\nB9\n");
    // a MINSERT of 32767 x 32767 copies (clamped to 4096 x 4096, still 16 million)
    let array = drawing(&blocks, "0\nINSERT\n2\nB0\n70\n32767\n71\n32767\n44\n0\n45\n0\n");
    // a line a million kilometres long, and a circle of 3 km
    let long = drawing("", "0\nLINE\n10\n0\n20\n0\n11\n1e9\n21\n0\n");
    let circle = drawing("", "0\nCIRCLE\n10\n0\n20\n0\n40\n1500\n");
    for (text, why) in [
        (&bomb, "block instances"),
        (&array, "block instances"),
        (&long, "more than the 2000 m"),
        (&circle, "more than the 2000 m"),
    ] {
        let (result, largest, took) = measured(|| dxf_import().parse(text.as_bytes(), Path::new("bomb.dxf")));
        let e = result.expect_err(why).to_string();
        assert!(e.contains(why) && e.starts_with("bomb.dxf"), "{why}: {e}");
        assert!(largest < 1 << 20, "{why}: allocated {largest} bytes at once");
        assert!(took < Duration::from_secs(1), "{why}: took {took:?}");
    }
    // a 2 km square at 5 cm is 1.6 billion cells: refused by count before the grid
    let square = drawing("", "0\nLWPOLYLINE\n70\n1\n10\n0\n20\n0\n10\n1990\n20\n0\n10\n1990\n20\n1990\n");
    let (result, largest, _) = measured(|| DxfImport::default().parse(square.as_bytes(), Path::new("big.dxf")));
    assert!(matches!(result, Err(MapError::TooLarge { .. })), "{result:?}");
    assert!(largest < 1 << 20, "allocated {largest} bytes at once");
}
