//! Organized point clouds in PCL's PCD format (v0.5–v0.7): `ascii`, `binary` and
//! `binary_compressed` (LZF) bodies. Only `x`, `y`, `z` are kept (camera optical
//! frame, metres); other fields (`rgba`, normals, padding `_`) are skipped.
//!
//! Layouts follow PCL's `PCDWriter`: `binary` is one record per point (fields in
//! header order); `binary_compressed` is two little-endian u32 (compressed size,
//! uncompressed size), then an LZF stream that decompresses to one block per field
//! holding that field for all points (structure of arrays).

use std::path::Path;

use super::{in_file, lzf, read_bytes, FormatError, FormatProblem};

/// An organized cloud: `width * height` points in row-major order, camera optical
/// frame (x right, y down, z forward), metres. Invalid points are all-NaN.
#[derive(Debug, Clone, PartialEq)]
pub struct OrganizedCloud {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Row-major points; `[NaN; 3]` where the sensor saw nothing.
    pub points: Vec<[f32; 3]>,
}

impl OrganizedCloud {
    /// Number of points with finite coordinates.
    pub fn valid_count(&self) -> usize {
        self.points.iter().filter(|p| p[2].is_finite()).count()
    }
}

/// Refuse clouds larger than this many points before allocating (a 4K sensor has 8.3 M).
const MAX_POINTS: usize = 1 << 25;

/// Refuse point records wider than this (PCL's widest point types take under 100
/// bytes), so sizes computed from `SIZE` x `COUNT` cannot overflow.
const MAX_RECORD_BYTES: usize = 1 << 16;

/// Reads an organized PCD file.
pub fn read(path: &Path) -> Result<OrganizedCloud, FormatError> {
    let bytes = read_bytes(path)?;
    in_file(path, parse(&bytes))
}

/// Scalar type of one field, from the header's `TYPE` and `SIZE`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    F32,
    F64,
    /// Any integer or a field we skip; only its byte size matters.
    Other(usize),
}

impl Scalar {
    fn size(self) -> usize {
        match self {
            Scalar::F32 => 4,
            Scalar::F64 => 8,
            Scalar::Other(n) => n,
        }
    }
}

#[derive(Debug, Clone)]
struct Field {
    name: String,
    scalar: Scalar,
    count: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Body {
    Ascii,
    Binary,
    BinaryCompressed,
}

#[derive(Debug)]
struct Header {
    fields: Vec<Field>,
    width: usize,
    height: usize,
    points: usize,
    body: Body,
    /// Byte offset of the body.
    body_start: usize,
}

/// Parses an organized PCD from memory.
pub fn parse(bytes: &[u8]) -> Result<OrganizedCloud, FormatProblem> {
    let header = parse_header(bytes)?;
    let body = &bytes[header.body_start..];
    let xyz = xyz_fields(&header.fields)?;
    // A forged WIDTH x HEIGHT must not reserve memory for points the body cannot hold:
    // an ascii value takes a byte at least, an LZF byte expands `MAX_EXPANSION` at most.
    let record = record_size(&header.fields);
    let least_body = match header.body {
        Body::Ascii => header.points * header.fields.iter().map(|f| f.count).sum::<usize>(),
        Body::Binary => header.points * record,
        Body::BinaryCompressed => header.points * record / lzf::MAX_EXPANSION,
    };
    if body.len() < least_body {
        return Err(FormatProblem::Truncated(format!(
            "{} body bytes cannot hold {} points of {record} bytes",
            body.len(),
            header.points
        )));
    }
    let mut points = vec![[f32::NAN; 3]; header.points];
    match header.body {
        Body::Ascii => read_ascii(body, &header, xyz, &mut points)?,
        Body::Binary => read_binary(body, &header, xyz, &mut points)?,
        Body::BinaryCompressed => read_compressed(body, &header, xyz, &mut points)?,
    }
    for p in &mut points {
        if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) {
            *p = [f32::NAN; 3];
        }
    }
    Ok(OrganizedCloud { width: header.width as u32, height: header.height as u32, points })
}

fn bad(line: usize, reason: impl Into<String>) -> FormatProblem {
    FormatProblem::BadHeader { line, reason: reason.into() }
}

fn parse_count(line: usize, key: &str, token: &str) -> Result<usize, FormatProblem> {
    token.parse::<usize>().map_err(|_| bad(line, format!("{key} value {token:?} is not a non-negative integer")))
}

fn parse_header(bytes: &[u8]) -> Result<Header, FormatProblem> {
    let mut names: Option<Vec<String>> = None;
    let mut sizes: Option<Vec<usize>> = None;
    let mut types: Option<(usize, Vec<char>)> = None;
    let mut counts: Option<Vec<usize>> = None;
    let mut width = None;
    let mut height = None;
    let mut points = None;
    let mut pos = 0;
    let mut line_no = 0;
    loop {
        if pos >= bytes.len() {
            return Err(FormatProblem::MissingHeader("DATA"));
        }
        line_no += 1;
        let end = bytes[pos..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| pos + i);
        let raw = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        let text = std::str::from_utf8(raw).map_err(|_| bad(line_no, "not text"))?.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let mut tokens = text.split_whitespace();
        let key = tokens.next().unwrap_or_default().to_ascii_uppercase();
        let values: Vec<&str> = tokens.collect();
        let one = |values: &[&str]| -> Result<usize, FormatProblem> {
            match values {
                [v] => parse_count(line_no, &key, v),
                _ => Err(bad(line_no, format!("{key} takes one value, got {}", values.len()))),
            }
        };
        match key.as_str() {
            "VERSION" | "VIEWPOINT" => {}
            "FIELDS" | "COLUMNS" => names = Some(values.iter().map(|s| s.to_string()).collect()),
            "SIZE" => sizes = Some(values.iter().map(|v| parse_count(line_no, "SIZE", v)).collect::<Result<_, _>>()?),
            "TYPE" => {
                let kinds = values
                    .iter()
                    .map(|v| match v.to_ascii_uppercase().as_str() {
                        "F" => Ok('F'),
                        "I" => Ok('I'),
                        "U" => Ok('U'),
                        other => Err(bad(line_no, format!("TYPE {other:?} is not F, I or U"))),
                    })
                    .collect::<Result<_, _>>()?;
                types = Some((line_no, kinds));
            }
            "COUNT" => {
                counts = Some(values.iter().map(|v| parse_count(line_no, "COUNT", v)).collect::<Result<_, _>>()?)
            }
            "WIDTH" => width = Some(one(&values)?),
            "HEIGHT" => height = Some(one(&values)?),
            "POINTS" => points = Some(one(&values)?),
            "DATA" => {
                let body = match values.first().map(|s| s.to_ascii_lowercase()).as_deref() {
                    Some("ascii") => Body::Ascii,
                    Some("binary") => Body::Binary,
                    Some("binary_compressed") => Body::BinaryCompressed,
                    Some(other) => {
                        return Err(FormatProblem::Unsupported(format!("DATA kind {other:?} (line {line_no})")))
                    }
                    None => return Err(bad(line_no, "DATA without a kind")),
                };
                let names = names.ok_or(FormatProblem::MissingHeader("FIELDS"))?;
                let sizes = sizes.ok_or(FormatProblem::MissingHeader("SIZE"))?;
                let (type_line, types) = types.ok_or(FormatProblem::MissingHeader("TYPE"))?;
                let counts = counts.unwrap_or_else(|| vec![1; names.len()]);
                if sizes.len() != names.len() || types.len() != names.len() || counts.len() != names.len() {
                    return Err(bad(
                        line_no,
                        format!(
                            "{} FIELDS but {} SIZE, {} TYPE, {} COUNT",
                            names.len(),
                            sizes.len(),
                            types.len(),
                            counts.len()
                        ),
                    ));
                }
                let fields = names
                    .into_iter()
                    .zip(sizes)
                    .zip(types)
                    .zip(counts)
                    .map(|(((name, size), kind), count)| {
                        let scalar = match (kind, size) {
                            ('F', 4) => Scalar::F32,
                            ('F', 8) => Scalar::F64,
                            ('F', n) => {
                                return Err(FormatProblem::Unsupported(format!(
                                    "field type: {name} is a float of {n} bytes (line {type_line})"
                                )))
                            }
                            (_, n @ (1 | 2 | 4 | 8)) => Scalar::Other(n),
                            (_, n) => {
                                return Err(FormatProblem::Unsupported(format!(
                                    "field type: {name} is an integer of {n} bytes (line {type_line})"
                                )))
                            }
                        };
                        Ok(Field { name, scalar, count })
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                let record = fields.iter().try_fold(0usize, |sum, f| {
                    f.scalar.size().checked_mul(f.count).and_then(|bytes| sum.checked_add(bytes))
                });
                if record.is_none_or(|bytes| bytes > MAX_RECORD_BYTES) {
                    return Err(FormatProblem::Unsupported(format!(
                        "point records over {MAX_RECORD_BYTES} bytes (SIZE x COUNT, line {type_line})"
                    )));
                }
                let width = width.ok_or(FormatProblem::MissingHeader("WIDTH"))?;
                let height = height.ok_or(FormatProblem::MissingHeader("HEIGHT"))?;
                let total = width.checked_mul(height).filter(|&n| n <= MAX_POINTS).ok_or_else(|| {
                    FormatProblem::Unsupported(format!("cloud size {width}x{height} (over {MAX_POINTS} points)"))
                })?;
                if height < 2 {
                    return Err(FormatProblem::Unsupported(format!(
                        "unorganized cloud (HEIGHT {height}): a depth image needs rows"
                    )));
                }
                let points = points.unwrap_or(total);
                if points != total {
                    return Err(bad(line_no, format!("POINTS {points} is not WIDTH x HEIGHT = {total}")));
                }
                return Ok(Header { fields, width, height, points, body, body_start: pos });
            }
            other => return Err(bad(line_no, format!("unknown keyword {other:?}"))),
        }
    }
}

/// Where x, y and z sit: (field index, byte offset within a binary record) per axis.
type XyzLayout = [(usize, usize); 3];

fn xyz_fields(fields: &[Field]) -> Result<XyzLayout, FormatProblem> {
    let mut layout = [(usize::MAX, 0); 3];
    let mut offset = 0;
    for (i, f) in fields.iter().enumerate() {
        if let Some(axis) = ["x", "y", "z"].iter().position(|a| *a == f.name) {
            if f.scalar == Scalar::Other(f.scalar.size()) {
                return Err(FormatProblem::Unsupported(format!("field type: {} must be a float", f.name)));
            }
            if f.count != 1 {
                return Err(FormatProblem::Unsupported(format!("field {} with COUNT {}", f.name, f.count)));
            }
            layout[axis] = (i, offset);
        }
        offset += f.scalar.size() * f.count;
    }
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        if layout[axis].0 == usize::MAX {
            return Err(FormatProblem::MissingHeader(match *name {
                "x" => "FIELDS x",
                "y" => "FIELDS y",
                _ => "FIELDS z",
            }));
        }
    }
    Ok(layout)
}

fn read_scalar(scalar: Scalar, bytes: &[u8]) -> f32 {
    match scalar {
        Scalar::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
        Scalar::F64 => {
            let mut b = [0u8; 8];
            b.copy_from_slice(&bytes[..8]);
            f64::from_le_bytes(b) as f32
        }
        Scalar::Other(_) => f32::NAN,
    }
}

fn record_size(fields: &[Field]) -> usize {
    fields.iter().map(|f| f.scalar.size() * f.count).sum()
}

fn read_binary(body: &[u8], header: &Header, xyz: XyzLayout, points: &mut [[f32; 3]]) -> Result<(), FormatProblem> {
    let record = record_size(&header.fields);
    let need = record * header.points;
    if body.len() < need {
        return Err(FormatProblem::Truncated(format!(
            "{} bytes for {} points of {record} bytes ({need} needed)",
            body.len(),
            header.points
        )));
    }
    for (p, rec) in points.iter_mut().zip(body.chunks_exact(record)) {
        for (axis, &(field, offset)) in xyz.iter().enumerate() {
            p[axis] = read_scalar(header.fields[field].scalar, &rec[offset..]);
        }
    }
    Ok(())
}

fn read_compressed(body: &[u8], header: &Header, xyz: XyzLayout, points: &mut [[f32; 3]]) -> Result<(), FormatProblem> {
    let sizes = body.get(..8).ok_or_else(|| FormatProblem::Truncated("no compressed-size words".into()))?;
    let compressed = u32::from_le_bytes([sizes[0], sizes[1], sizes[2], sizes[3]]) as usize;
    let uncompressed = u32::from_le_bytes([sizes[4], sizes[5], sizes[6], sizes[7]]) as usize;
    let need = record_size(&header.fields) * header.points;
    if uncompressed != need {
        return Err(FormatProblem::Corrupt(format!(
            "announces {uncompressed} uncompressed bytes, header implies {need}"
        )));
    }
    if uncompressed > compressed.saturating_mul(lzf::MAX_EXPANSION) {
        return Err(FormatProblem::Corrupt(format!("{compressed} compressed bytes cannot expand to {uncompressed}")));
    }
    let stream = body.get(8..8 + compressed).ok_or_else(|| {
        FormatProblem::Truncated(format!("{} of {compressed} compressed bytes present", body.len() - 8))
    })?;
    let mut soa = Vec::new();
    lzf::decompress(stream, uncompressed, &mut soa).map_err(|e| FormatProblem::Corrupt(e.to_string()))?;
    // Each field's block starts after the blocks of the fields before it.
    let mut block_start = Vec::with_capacity(header.fields.len());
    let mut start = 0;
    for f in &header.fields {
        block_start.push(start);
        start += f.scalar.size() * f.count * header.points;
    }
    for (axis, &(field, _)) in xyz.iter().enumerate() {
        let scalar = header.fields[field].scalar;
        let size = scalar.size();
        let block = &soa[block_start[field]..block_start[field] + size * header.points];
        for (p, v) in points.iter_mut().zip(block.chunks_exact(size)) {
            p[axis] = read_scalar(scalar, v);
        }
    }
    Ok(())
}

fn read_ascii(body: &[u8], header: &Header, xyz: XyzLayout, points: &mut [[f32; 3]]) -> Result<(), FormatProblem> {
    let text = std::str::from_utf8(body).map_err(|_| FormatProblem::Corrupt("ascii body is not text".into()))?;
    // Token index of each axis within a line: fields before it contribute COUNT tokens.
    let mut token_of = [0usize; 3];
    for (axis, &(field, _)) in xyz.iter().enumerate() {
        token_of[axis] = header.fields[..field].iter().map(|f| f.count).sum();
    }
    let tokens_per_line: usize = header.fields.iter().map(|f| f.count).sum();
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let mut tokens = Vec::with_capacity(tokens_per_line);
    for (i, p) in points.iter_mut().enumerate() {
        let line = lines
            .next()
            .ok_or_else(|| FormatProblem::Truncated(format!("{i} of {} point lines present", header.points)))?;
        tokens.clear();
        tokens.extend(line.split_whitespace());
        if tokens.len() != tokens_per_line {
            return Err(FormatProblem::Corrupt(format!(
                "point {i} has {} values, {tokens_per_line} expected",
                tokens.len()
            )));
        }
        for axis in 0..3 {
            let token = tokens[token_of[axis]];
            p[axis] = token
                .parse::<f32>()
                .map_err(|_| FormatProblem::Corrupt(format!("point {i}: {:?} is not a number", token)))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER_XYZ_RGBA: &str = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgba\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 3\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\n";

    fn sample_points() -> Vec<[f32; 3]> {
        vec![[0.1, 0.2, 1.0], [f32::NAN; 3], [-0.5, 0.25, 2.5], [0.0, 0.0, 0.75], [1.0, -1.0, 3.0], [f32::NAN; 3]]
    }

    fn same(a: &[[f32; 3]], b: &[[f32; 3]]) -> bool {
        a.len() == b.len()
            && a.iter().zip(b).all(|(p, q)| p.iter().zip(q).all(|(x, y)| x == y || (x.is_nan() && y.is_nan())))
    }

    fn binary_pcd(points: &[[f32; 3]]) -> Vec<u8> {
        let mut bytes = format!("{HEADER_XYZ_RGBA}DATA binary\n").into_bytes();
        for p in points {
            for v in p {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
            bytes.extend_from_slice(&0xff00ff00u32.to_le_bytes());
        }
        bytes
    }

    /// A `binary_compressed` body whose LZF stream is literal runs only (valid LZF).
    fn compressed_pcd(points: &[[f32; 3]]) -> Vec<u8> {
        let mut soa = Vec::new();
        for axis in 0..3 {
            for p in points {
                soa.extend_from_slice(&p[axis].to_le_bytes());
            }
        }
        soa.extend(std::iter::repeat_n(7u8, 4 * points.len()));
        let mut lzf = Vec::new();
        for chunk in soa.chunks(32) {
            lzf.push(chunk.len() as u8 - 1);
            lzf.extend_from_slice(chunk);
        }
        let mut bytes = format!("{HEADER_XYZ_RGBA}DATA binary_compressed\n").into_bytes();
        bytes.extend_from_slice(&(lzf.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&(soa.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&lzf);
        bytes
    }

    #[test]
    fn ascii_cloud_keeps_xyz_and_nan() {
        let text = format!(
            "{HEADER_XYZ_RGBA}DATA ascii\n0.1 0.2 1 4278190080\nnan nan nan 0\n-0.5 0.25 2.5 1\n0 0 0.75 2\n1 -1 3 3\nNaN NaN NaN 0\n"
        );
        let cloud = parse(text.as_bytes()).unwrap();
        assert_eq!((cloud.width, cloud.height), (3, 2));
        assert!(same(&cloud.points, &sample_points()));
        assert_eq!(cloud.valid_count(), 4);
    }

    #[test]
    fn binary_cloud_skips_rgba() {
        let cloud = parse(&binary_pcd(&sample_points())).unwrap();
        assert!(same(&cloud.points, &sample_points()));
    }

    #[test]
    fn compressed_cloud_reads_field_blocks() {
        let cloud = parse(&compressed_pcd(&sample_points())).unwrap();
        assert!(same(&cloud.points, &sample_points()));
    }

    #[test]
    fn truncated_binary_body_is_refused() {
        let bytes = binary_pcd(&sample_points());
        let err = parse(&bytes[..bytes.len() - 3]).unwrap_err();
        assert!(matches!(err, FormatProblem::Truncated(_)), "{err}");
    }

    #[test]
    fn truncated_ascii_body_is_refused() {
        let text = format!("{HEADER_XYZ_RGBA}DATA ascii\n0.1 0.2 1 4278190080\n");
        assert!(matches!(parse(text.as_bytes()), Err(FormatProblem::Truncated(_))));
    }

    #[test]
    fn bad_width_names_its_line() {
        let text = HEADER_XYZ_RGBA.replace("WIDTH 3", "WIDTH three") + "DATA ascii\n";
        assert_eq!(
            parse(text.as_bytes()).unwrap_err(),
            FormatProblem::BadHeader { line: 7, reason: "WIDTH value \"three\" is not a non-negative integer".into() }
        );
    }

    #[test]
    fn integer_z_is_unsupported() {
        let text = HEADER_XYZ_RGBA.replace("TYPE F F F U", "TYPE F F U U") + "DATA ascii\n";
        let err = parse(text.as_bytes()).unwrap_err();
        assert_eq!(err, FormatProblem::Unsupported("field type: z must be a float".into()));
    }

    #[test]
    fn missing_z_field_is_refused() {
        let text = HEADER_XYZ_RGBA.replace("FIELDS x y z rgba", "FIELDS x y w rgba") + "DATA ascii\n";
        assert_eq!(parse(text.as_bytes()).unwrap_err(), FormatProblem::MissingHeader("FIELDS z"));
    }

    #[test]
    fn header_without_data_line_is_refused() {
        assert_eq!(parse(HEADER_XYZ_RGBA.as_bytes()).unwrap_err(), FormatProblem::MissingHeader("DATA"));
    }

    #[test]
    fn unorganized_cloud_is_refused() {
        let text = HEADER_XYZ_RGBA.replace("WIDTH 3", "WIDTH 6").replace("HEIGHT 2", "HEIGHT 1") + "DATA ascii\n";
        assert!(matches!(parse(text.as_bytes()), Err(FormatProblem::Unsupported(_))));
    }

    #[test]
    fn absurd_uncompressed_size_is_refused_before_allocating() {
        let mut bytes = format!("{HEADER_XYZ_RGBA}DATA binary_compressed\n").into_bytes();
        bytes.extend_from_slice(&1u32.to_le_bytes());
        bytes.extend_from_slice(&96u32.to_le_bytes());
        bytes.push(0);
        assert!(matches!(parse(&bytes), Err(FormatProblem::Corrupt(_))));
    }

    #[test]
    fn read_names_the_missing_file() {
        let err = read(Path::new("/nonexistent/cloud.pcd")).unwrap_err();
        assert!(err.to_string().starts_with("/nonexistent/cloud.pcd: cannot read"), "{err}");
    }

    /// PCL's own `binary_compressed` output (LZF with back-references, padding after the
    /// stream), the one real PCD kept in the repository: the other two PCL captures the
    /// tests use are kept as depth PNGs (`tests/data/README.md`).
    #[test]
    fn five_people_has_239075_valid_points() {
        let bytes = crate::test_data::real_capture_bytes("five_people.pcd");
        let cloud = parse(&bytes).unwrap();
        assert_eq!((cloud.width, cloud.height), (640, 480));
        assert_eq!(cloud.valid_count(), 239_075);
        let (lo, hi) = cloud
            .points
            .iter()
            .filter(|p| p[2].is_finite())
            .fold((f32::MAX, f32::MIN), |(lo, hi), p| (lo.min(p[2]), hi.max(p[2])));
        assert!((lo - 1.76).abs() < 0.01 && (hi - 9.76).abs() < 0.01, "z {lo}..{hi}");
        // Any cut through the compressed body is reported, never a panic.
        // PCL leaves 3,901 bytes of padding after the LZF stream in its files.
        for cut in [bytes.len() - 4000, bytes.len() / 2, 300, 10] {
            assert!(parse(&bytes[..cut]).is_err(), "cut at {cut} accepted");
        }
        // Flipped bytes inside the LZF stream decode to an error or to some cloud.
        let mut corrupt = bytes.clone();
        for i in (400..corrupt.len()).step_by(997) {
            corrupt[i] ^= 0x5a;
        }
        let _ = parse(&corrupt);
    }

    #[test]
    fn real_cloud_round_trips_through_binary_layout() {
        let bytes = crate::test_data::real_capture_bytes("five_people.pcd");
        let cloud = parse(&bytes).unwrap();
        let mut text = HEADER_XYZ_RGBA.replace("WIDTH 3", "WIDTH 640").replace("HEIGHT 2", "HEIGHT 480");
        text = text.replace("POINTS 6", "POINTS 307200");
        let mut binary = format!("{text}DATA binary\n").into_bytes();
        for p in &cloud.points {
            for v in p {
                binary.extend_from_slice(&v.to_le_bytes());
            }
            binary.extend_from_slice(&[0; 4]);
        }
        assert!(same(&parse(&binary).unwrap().points, &cloud.points));
    }
}
