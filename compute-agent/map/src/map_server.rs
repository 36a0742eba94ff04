//! The ROS `map_server` format: a YAML file naming an image (PGM or PNG) and saying how
//! to read it, with map_server's semantics (ROS wiki `map_server`, "Value Interpretation"):
//!
//! - the colour of a pixel is the mean of its non-alpha channels; `p = (255 - colour) / 255`,
//!   or `p = colour / 255` when `negate` is set;
//! - `p > occupied_thresh` is occupied, `p < free_thresh` is free, anything else unknown
//!   (`trinary`, the default); `scale` grades the pixels between the thresholds (unknown
//!   when translucent), which are unknown here as cells have no grades;
//!   `raw` reads the colour as the occupancy value itself (0..=100 a percentage, judged
//!   by the same thresholds; above 100, e.g. 255 for -1, unknown);
//! - the image's top row is the map's largest y; `origin` is the pose of the lower-left
//!   pixel's corner (x, y, yaw).
//!
//! [`write_map`] writes what map_saver writes: trinary PGM (254 free, 0 occupied, 205
//! unknown) with `occupied_thresh: 0.65`, `free_thresh: 0.196`.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::MapError;
use crate::grid::{check_resolution, check_size, Cell, OccupancyGrid, Origin, MAX_CELLS};
use crate::pgm::{decode_pgm, encode_pgm, GrayImage};

/// Files larger than this are refused before they are read (a 64 M-cell 16-bit PGM is 128 MiB).
pub const MAX_FILE_BYTES: u64 = 256 * 1024 * 1024;

/// The most bytes deflate (a PNG's compression) can pack into one: 258-byte matches
/// coded in about 2 bits each (RFC 1951; zlib's technical details say 1032:1).
pub const MAX_DEFLATE_RATIO: u64 = 1032;

/// How pixel values become cells (map_server's `mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MapMode {
    /// occupied / free / unknown by the thresholds (map_server's default)
    Trinary,
    /// graded between the thresholds in map_server; unknown here, like trinary
    Scale,
    /// the pixel value is the occupancy value
    Raw,
}

/// The fields of a map_server YAML file.
#[derive(Clone, Debug, PartialEq)]
pub struct MapMetadata {
    /// the image path as written in the YAML (relative to the YAML's folder unless absolute)
    pub image: PathBuf,
    /// metres per pixel
    pub resolution_m: f64,
    /// pose of the lower-left pixel's corner
    pub origin: Origin,
    /// p above this is occupied
    pub occupied_thresh: f64,
    /// p below this is free
    pub free_thresh: f64,
    /// white is occupied instead of black
    pub negate: bool,
    /// how pixels become cells
    pub mode: MapMode,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Flag {
    Bool(bool),
    Int(i64),
}

#[derive(Deserialize)]
struct RawYaml {
    image: String,
    resolution: f64,
    origin: Vec<f64>,
    occupied_thresh: f64,
    free_thresh: f64,
    negate: Flag,
    #[serde(default)]
    mode: Option<MapMode>,
}

/// Flow collections (`[`, `{`) nested deeper than this are refused before the YAML
/// parser sees them: its time grows with the square of the depth (100,000 nested `{a: `,
/// 400 KB, took 29 s), and a map YAML nests one level (`origin: [x, y, yaw]`).
pub const MAX_YAML_NESTING: usize = 64;

/// Parses and checks a map YAML's text; `file` names it in errors.
pub fn parse_map_yaml(text: &str, file: &Path) -> Result<MapMetadata, MapError> {
    check_nesting(text, file)?;
    let raw: RawYaml = serde_yaml_ng::from_str(text).map_err(|e| MapError::Yaml {
        file: file.to_path_buf(),
        // the YAML parser puts the end of a text without a final newline on the line
        // after it: that is the last line
        line: e.location().map_or(0, |l| l.line().min(crate::error::line_of(text, text.len()))),
        message: e.to_string(),
    })?;
    let bad = |field: &'static str, message: String| MapError::BadField { file: file.to_path_buf(), field, message };
    check_resolution(file, raw.resolution)?;
    let origin = match raw.origin[..] {
        [x, y, yaw] if x.is_finite() && y.is_finite() && yaw.is_finite() => Origin { x_m: x, y_m: y, yaw_rad: yaw },
        _ => return Err(bad("origin", format!("must be three finite numbers [x, y, yaw], got {:?}", raw.origin))),
    };
    let (free, occupied) = (raw.free_thresh, raw.occupied_thresh);
    if !(0.0..=1.0).contains(&free) || !(0.0..=1.0).contains(&occupied) || free >= occupied {
        return Err(MapError::Thresholds { file: file.to_path_buf(), free, occupied });
    }
    let negate = match raw.negate {
        Flag::Bool(b) => b,
        Flag::Int(0) => false,
        Flag::Int(1) => true,
        Flag::Int(n) => return Err(bad("negate", format!("must be 0 or 1 (or true/false), got {n}"))),
    };
    if raw.image.trim().is_empty() {
        return Err(bad("image", "is empty: name the .pgm or .png next to the YAML".into()));
    }
    Ok(MapMetadata {
        image: PathBuf::from(raw.image),
        resolution_m: raw.resolution,
        origin,
        occupied_thresh: occupied,
        free_thresh: free,
        negate,
        mode: raw.mode.unwrap_or(MapMode::Trinary),
    })
}

/// Refuses text whose brackets open more than [`MAX_YAML_NESTING`] deep (brackets in
/// quotes and comments count too: a map YAML has none to spare).
fn check_nesting(text: &str, file: &Path) -> Result<(), MapError> {
    let mut depth = 0usize;
    for (i, b) in text.bytes().enumerate() {
        match b {
            b'[' | b'{' => depth += 1,
            b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
        if depth > MAX_YAML_NESTING {
            return Err(MapError::Yaml {
                file: file.to_path_buf(),
                line: crate::error::line_of(text, i),
                message: format!("brackets nested more than {MAX_YAML_NESTING} deep: a map YAML is flat"),
            });
        }
    }
    Ok(())
}

/// Reads a whole file after checking its size against [`MAX_FILE_BYTES`].
pub(crate) fn read_limited(file: &Path) -> Result<Vec<u8>, MapError> {
    let io = |source| MapError::Io { file: file.to_path_buf(), action: "cannot read", source };
    let bytes = std::fs::metadata(file).map_err(io)?.len();
    if bytes > MAX_FILE_BYTES {
        return Err(MapError::FileTooLarge { file: file.to_path_buf(), bytes, limit: MAX_FILE_BYTES });
    }
    std::fs::read(file).map_err(io)
}

/// Loads a map_server map: the YAML at `yaml_path` and the image it names.
pub fn load_map(yaml_path: &Path) -> Result<OccupancyGrid, MapError> {
    let bytes = read_limited(yaml_path)?;
    let text = std::str::from_utf8(&bytes).map_err(|e| MapError::Yaml {
        file: yaml_path.to_path_buf(),
        line: crate::error::line_of(&String::from_utf8_lossy(&bytes), e.valid_up_to()),
        message: "not UTF-8 text".into(),
    })?;
    let meta = parse_map_yaml(text, yaml_path)?;
    let image_path = match yaml_path.parent() {
        Some(dir) if meta.image.is_relative() => dir.join(&meta.image),
        _ => meta.image.clone(),
    };
    let image = decode_image(&image_path)?;
    grid_from_image(&meta, &image, &image_path)
}

/// Decodes a `.pgm` or `.png` file by its extension.
pub fn decode_image(path: &Path) -> Result<GrayImage, MapError> {
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    match extension.as_str() {
        "pgm" => decode_pgm(&read_limited(path)?, path),
        "png" => decode_png(&read_limited(path)?, path),
        _ => Err(MapError::UnknownImageFormat { file: path.to_path_buf(), extension }),
    }
}

/// Decodes a PNG (grey, grey+alpha, RGB, RGBA, palette; 1 to 16 bits) to the mean of its
/// colour channels, keeping alpha. The size is checked before the pixels are allocated.
pub fn decode_png(bytes: &[u8], file: &Path) -> Result<GrayImage, MapError> {
    let png_err = |e: png::DecodingError| MapError::Png { file: file.to_path_buf(), message: e.to_string() };
    let limits = png::Limits { bytes: (MAX_CELLS * 8) as usize };
    let mut decoder = png::Decoder::new_with_limits(bytes, limits);
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(png_err)?;
    let (width, height) = (reader.info().width as u64, reader.info().height as u64);
    check_size(file, width, height)?;
    // a forged IHDR must not size the buffer: deflate packs at most MAX_DEFLATE_RATIO
    // bytes into one, so the file must be large enough for the rows it declares
    let raw = reader.info().raw_bytes() as u64;
    if raw > MAX_DEFLATE_RATIO * bytes.len() as u64 {
        return Err(MapError::Png {
            file: file.to_path_buf(),
            message: format!(
                "{width} x {height} pixels cannot fit in {} bytes (a PNG compresses at most {MAX_DEFLATE_RATIO} to 1)",
                bytes.len()
            ),
        });
    }
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(png_err)?;
    let (channels, has_alpha) = match info.color_type {
        png::ColorType::Grayscale => (1, false),
        png::ColorType::GrayscaleAlpha => (2, true),
        png::ColorType::Rgb => (3, false),
        png::ColorType::Rgba => (4, true),
        png::ColorType::Indexed => {
            return Err(MapError::Png { file: file.to_path_buf(), message: "palette was not expanded".into() })
        }
    };
    let colour = channels - usize::from(has_alpha);
    let (w, h) = (width as usize, height as usize);
    let mut pixels = Vec::with_capacity(w * h);
    let mut alpha = Vec::with_capacity(if has_alpha { w * h } else { 0 });
    for row in buf.chunks(info.line_size).take(h) {
        for px in row.chunks_exact(channels).take(w) {
            let sum: u32 = px[..colour].iter().map(|&v| v as u32).sum();
            pixels.push((sum / colour as u32) as u8);
            if has_alpha {
                alpha.push(px[colour]);
            }
        }
    }
    if pixels.len() != w * h {
        return Err(MapError::SizeMismatch {
            file: file.to_path_buf(),
            width,
            height,
            expected: width * height,
            found: pixels.len() as u64,
        });
    }
    Ok(GrayImage { width: w, height: h, pixels, alpha })
}

/// The cell map_server would make of one pixel.
pub fn classify(meta: &MapMetadata, colour: u8, alpha: u8) -> Cell {
    let by_p = |p: f64| {
        if p > meta.occupied_thresh {
            Cell::Occupied
        } else if p < meta.free_thresh {
            Cell::Free
        } else {
            Cell::Unknown
        }
    };
    match meta.mode {
        MapMode::Raw => {
            let v = if meta.negate { 255 - colour } else { colour };
            if v <= 100 {
                by_p(v as f64 / 100.0)
            } else {
                Cell::Unknown
            }
        }
        MapMode::Trinary | MapMode::Scale => {
            let c = colour as f64;
            let p = if meta.negate { c / 255.0 } else { (255.0 - c) / 255.0 };
            // map_server's scale mode gives a pixel between the thresholds a graded
            // value (unknown when translucent); cells here have no grades, so it is unknown
            let _ = alpha;
            by_p(p)
        }
    }
}

/// The grid a decoded image makes under `meta`; flips the rows (image top = largest y).
pub fn grid_from_image(meta: &MapMetadata, image: &GrayImage, file: &Path) -> Result<OccupancyGrid, MapError> {
    check_size(file, image.width as u64, image.height as u64)?;
    let (w, h) = (image.width, image.height);
    if image.pixels.len() != w * h {
        return Err(MapError::SizeMismatch {
            file: file.to_path_buf(),
            width: w as u64,
            height: h as u64,
            expected: (w * h) as u64,
            found: image.pixels.len() as u64,
        });
    }
    let mut cells = Vec::with_capacity(w * h);
    for row in 0..h {
        let img_row = h - 1 - row;
        for col in 0..w {
            let i = img_row * w + col;
            let alpha = image.alpha.get(i).copied().unwrap_or(255);
            cells.push(classify(meta, image.pixels[i], alpha));
        }
    }
    OccupancyGrid::new(w, h, meta.resolution_m, meta.origin, cells).map_err(|e| relabel(e, file))
}

fn relabel(e: MapError, file: &Path) -> MapError {
    match e {
        MapError::Resolution { value, .. } => MapError::Resolution { file: file.to_path_buf(), value },
        other => other,
    }
}

/// The grey value map_saver writes for a cell (trinary).
pub fn trinary_value(cell: Cell) -> u8 {
    match cell {
        Cell::Free => 254,
        Cell::Occupied => 0,
        Cell::Unknown => 205,
    }
}

/// Writes `grid` as map_saver does: `yaml_path` plus a trinary P5 PGM of the same stem
/// beside it. Returns the PGM's path.
pub fn write_map(grid: &OccupancyGrid, yaml_path: &Path) -> Result<PathBuf, MapError> {
    let stem =
        yaml_path.file_stem().and_then(|s| s.to_str()).filter(|s| !s.is_empty()).ok_or_else(|| MapError::BadField {
            file: yaml_path.to_path_buf(),
            field: "image",
            message: "the YAML path needs a UTF-8 file name to name the PGM after".into(),
        })?;
    let image_name = format!("{stem}.pgm");
    let pgm_path = yaml_path.with_file_name(&image_name);
    let (w, h) = (grid.width(), grid.height());
    let mut pixels = Vec::with_capacity(w * h);
    for img_row in 0..h {
        let row = h - 1 - img_row;
        pixels.extend(grid.cells()[row * w..(row + 1) * w].iter().map(|&c| trinary_value(c)));
    }
    let image = GrayImage { width: w, height: h, pixels, alpha: Vec::new() };
    let pgm = encode_pgm(&image, &format!("CREATOR: wearnav map {} m/pix", grid.resolution_m()));
    let o = grid.origin();
    let yaml = format!(
        "image: {image_name}\nmode: trinary\nresolution: {}\norigin: [{}, {}, {}]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
        fmt_f64(grid.resolution_m()),
        fmt_f64(o.x_m),
        fmt_f64(o.y_m),
        fmt_f64(o.yaw_rad)
    );
    let io = |file: &Path| {
        let file = file.to_path_buf();
        move |source| MapError::Io { file, action: "cannot write", source }
    };
    std::fs::write(&pgm_path, pgm).map_err(io(&pgm_path))?;
    std::fs::write(yaml_path, yaml).map_err(io(yaml_path))?;
    Ok(pgm_path)
}

/// Shortest exact decimal, always with a decimal point so YAML reads a float.
fn fmt_f64(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains(['.', 'e', 'E']) {
        s
    } else {
        format!("{s}.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const YAML: &str = "image: m.pgm\nresolution: 0.05\norigin: [-1.0, -2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";

    fn meta(mode: MapMode, negate: bool) -> MapMetadata {
        let mut m = parse_map_yaml(YAML, Path::new("m.yaml")).unwrap();
        m.mode = mode;
        m.negate = negate;
        m
    }

    #[test]
    fn trinary_values_follow_map_server() {
        let m = meta(MapMode::Trinary, false);
        assert_eq!(classify(&m, 254, 255), Cell::Free);
        assert_eq!(classify(&m, 0, 255), Cell::Occupied);
        assert_eq!(classify(&m, 205, 255), Cell::Unknown); // p = 0.19608 > 0.196
        assert_eq!(classify(&m, 206, 255), Cell::Free); // p = 0.19216 < 0.196
        assert_eq!(classify(&m, 89, 255), Cell::Occupied); // p = 0.651 > 0.65
        assert_eq!(classify(&m, 90, 255), Cell::Unknown); // p = 0.647
        let n = meta(MapMode::Trinary, true);
        assert_eq!(classify(&n, 254, 255), Cell::Occupied);
        assert_eq!(classify(&n, 0, 255), Cell::Free);
    }

    #[test]
    fn raw_mode_reads_the_value_as_occupancy() {
        let m = meta(MapMode::Raw, false);
        assert_eq!(classify(&m, 0, 255), Cell::Free);
        assert_eq!(classify(&m, 100, 255), Cell::Occupied);
        assert_eq!(classify(&m, 50, 255), Cell::Unknown);
        assert_eq!(classify(&m, 255, 255), Cell::Unknown);
    }

    #[test]
    fn scale_mode_judges_translucent_pixels_by_colour_outside_the_thresholds() {
        let m = meta(MapMode::Scale, false);
        let img = GrayImage { width: 3, height: 1, pixels: vec![254, 0, 128], alpha: vec![100, 100, 255] };
        let g = grid_from_image(&m, &img, Path::new("x.png")).unwrap();
        assert_eq!(g.cells(), &[Cell::Free, Cell::Occupied, Cell::Unknown]);
    }

    #[test]
    fn image_top_row_is_the_largest_y() {
        let m = meta(MapMode::Trinary, false);
        // top row: occupied, free; bottom row: free, unknown
        let img = GrayImage { width: 2, height: 2, pixels: vec![0, 254, 254, 205], alpha: vec![] };
        let g = grid_from_image(&m, &img, Path::new("x.pgm")).unwrap();
        assert_eq!(g.get(0, 1), Some(Cell::Occupied));
        assert_eq!(g.get(1, 1), Some(Cell::Free));
        assert_eq!(g.get(0, 0), Some(Cell::Free));
        assert_eq!(g.get(1, 0), Some(Cell::Unknown));
    }

    #[test]
    fn yaml_fields_are_checked() {
        let p = Path::new("bad.yaml");
        let with = |from: &str, to: &str| parse_map_yaml(&YAML.replace(from, to), p);
        assert!(matches!(with("resolution: 0.05", "resolution: 0"), Err(MapError::Resolution { .. })));
        assert!(matches!(with("resolution: 0.05", "resolution: -0.05"), Err(MapError::Resolution { .. })));
        assert!(matches!(with("resolution: 0.05", "resolution: .nan"), Err(MapError::Resolution { .. })));
        assert!(matches!(with("resolution: 0.05", "resolution: 11"), Err(MapError::Resolution { .. })));
        assert!(matches!(with("free_thresh: 0.196", "free_thresh: 0.7"), Err(MapError::Thresholds { .. })));
        assert!(matches!(with("free_thresh: 0.196", "free_thresh: -0.1"), Err(MapError::Thresholds { .. })));
        assert!(matches!(with("negate: 0", "negate: 2"), Err(MapError::BadField { field: "negate", .. })));
        assert!(matches!(with("[-1.0, -2.0, 0.0]", "[-1.0, -2.0]"), Err(MapError::BadField { field: "origin", .. })));
        assert!(with("negate: 0", "negate: true").unwrap().negate);
        assert_eq!(with("negate: 0", "negate: 0\nmode: scale").unwrap().mode, MapMode::Scale);
        assert!(matches!(with("negate: 0", "negate: 0\nmode: fancy"), Err(MapError::Yaml { .. })));
    }

    #[test]
    fn malformed_yaml_names_file_and_line() {
        let text = "image: m.pgm\nresolution: 0.05\norigin: [1, 2\nnegate: 0\n";
        let e = parse_map_yaml(text, Path::new("broken.yaml")).unwrap_err();
        match &e {
            MapError::Yaml { line, .. } => assert!(*line >= 3, "{e}"),
            other => panic!("{other}"),
        }
        assert!(e.to_string().starts_with("broken.yaml:"), "{e}");
        let missing = parse_map_yaml("image: m.pgm\n", Path::new("short.yaml")).unwrap_err();
        assert!(missing.to_string().contains("missing field"), "{missing}");
    }
}
