//! Depth image packing for [`DepthFrame`](crate::DepthFrame): raw, lossless, or
//! bounded-error. Each frame decodes on its own (no inter-frame state), so a lost
//! packet costs one frame, never a stream.
//!
//! The packed format (both compressed modes share it; the decoder needs no mode):
//!
//! 1. **Levels.** Structured-light cameras (Kinect, Xtion) measure disparity, so a
//!    frame holds only a few hundred distinct depths. The distinct valid samples are
//!    grouped into levels, sorted: lossless keeps one level per value; bounded mode
//!    greedily merges values spanning at most `2 * (step / 2)` units into one level
//!    whose value is the middle of its span, so every sample is within `step / 2`
//!    (at most as many levels as quantising to `step`, and never more error).
//!    Pixels are then coded as level indices, which are proportional to disparity:
//!    planes are (nearly) linear in them.
//! 2. **Validity.** Invalid (0) pixels are sent as per-row run lengths, never as
//!    depths, so they cannot become valid and valid pixels cannot become 0.
//! 3. **Prediction.** Each valid pixel's level is predicted with LOCO-I's median edge
//!    detector from its left, upper and upper-left neighbours (Weinberger, Seroussi,
//!    Sapiro 2000, "The LOCO-I lossless image compression algorithm", section 2.1).
//!    Invalid pixels take their prediction, so holes do not disturb their neighbours.
//! 4. **Entropy coding.** Zigzag residuals (255 = escape to a varint) are coded with
//!    rANS ([`rans`]) under 8 contexts: the activity of the row above (as LOCO-I's
//!    gradient contexts, section 2.3) and whether the previous residual was zero.
//!    Level values, run lengths and escapes go in a side stream coded with one more
//!    rANS model over bytes.
//!
//! Layout: `FORMAT_TAG`, varint side length, side model, varint side word count,
//! side words (u16 LE); 8 residual models, varint residual word count, residual words.
//! The side stream holds: level count, first level, level gaps; per row, alternating
//! valid/invalid run lengths summing to the width; then the escapes in pixel order.

mod rans;

use thiserror::Error;

use crate::messages::DepthEncoding;

/// Why a depth payload could not be packed or unpacked.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum CodecError {
    /// Sample count does not match width x height.
    #[error("{got} samples for a {width}x{height} image (expected {expected})")]
    SizeMismatch {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// width * height.
        expected: usize,
        /// Samples given or decoded.
        got: usize,
    },
    /// Compressed bytes that do not decode.
    #[error("corrupt depth payload: {0}")]
    Corrupt(String),
    /// A zero quantisation step.
    #[error("bounded encoding needs a step of at least 1 depth unit")]
    ZeroStep,
    /// Width x height beyond what any depth camera produces.
    #[error("{width}x{height} is larger than the {MAX_PIXELS}-pixel limit")]
    TooLarge {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
}

/// Largest image accepted (a 4096 x 4096 depth image), so a forged size cannot make
/// the decoder allocate without bound.
pub const MAX_PIXELS: usize = 1 << 24;

/// First byte of a compressed payload: format version 1.
const FORMAT_TAG: u8 = 0xD1;
/// Residual symbol meaning "the zigzag residual minus this follows as a varint".
const ESCAPE: u32 = 255;
/// Residual contexts: 4 activity classes x previous residual zero or not.
const CONTEXTS: usize = 8;

fn corrupt(what: &str) -> CodecError {
    CodecError::Corrupt(what.to_string())
}

fn checked_len(width: u32, height: u32) -> Result<usize, CodecError> {
    let n = width as usize * height as usize;
    if n > MAX_PIXELS {
        return Err(CodecError::TooLarge { width, height });
    }
    Ok(n)
}

/// Appends `v` as a little-endian base-128 varint.
fn put_varint(out: &mut Vec<u8>, mut v: u32) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// A bounds-checked reader over payload bytes.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn new(bytes: &'a [u8]) -> Cursor<'a> {
        Cursor { bytes, pos: 0 }
    }

    #[inline]
    fn varint(&mut self) -> Option<u32> {
        let mut v = 0u32;
        for shift in [0, 7, 14, 21, 28] {
            let b = *self.bytes.get(self.pos)?;
            self.pos += 1;
            v |= ((b & 0x7f) as u32).checked_shl(shift)?;
            if b < 0x80 {
                return if shift == 28 && b > 0x0f {
                    None
                } else {
                    Some(v)
                };
            }
        }
        None
    }

    fn byte(&mut self) -> Option<u8> {
        let b = *self.bytes.get(self.pos)?;
        self.pos += 1;
        Some(b)
    }

    fn words(&mut self, count: usize, out: &mut Vec<u16>) -> Option<()> {
        let end = self.pos.checked_add(count.checked_mul(2)?)?;
        let raw = self.bytes.get(self.pos..end)?;
        out.clear();
        out.extend(
            raw.chunks_exact(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]])),
        );
        self.pos = end;
        Some(())
    }
}

fn put_words(out: &mut Vec<u8>, words: &[u16]) {
    put_varint(out, words.len() as u32);
    out.reserve(words.len() * 2);
    for w in words {
        out.extend_from_slice(&w.to_le_bytes());
    }
}

/// Activity class of the row above: LOCO-I-style thresholds on |B-C| + |D-B|.
const ACTIVITY_CLASS: [u8; 8] = [0, 1, 1, 2, 2, 2, 2, 3];

/// LOCO-I median edge detector: `a` left, `b` up, `c` up-left.
#[inline(always)]
fn med(a: i32, b: i32, c: i32) -> i32 {
    // The median of a, b and a + b - c, without branches (edges are unpredictable).
    a.min(b)
        .max(a.max(b).min(a.wrapping_add(b).wrapping_sub(c)))
}

#[inline(always)]
fn context(b: i32, c: i32, d: i32, calm_above: bool) -> usize {
    let activity = ((b - c).unsigned_abs() + (d - b).unsigned_abs()).min(7);
    ACTIVITY_CLASS[activity as usize] as usize * 2 + calm_above as usize
}

/// Packs depth images; keeps its buffers between frames so a stream allocates once.
#[derive(Debug, Clone)]
pub struct DepthEncoder {
    present: Vec<bool>,
    level_of: Box<[u16; 65536]>,
    levels: Vec<u16>,
    rows: [Vec<i32>; 2],
    symbols: Vec<u8>,
    contexts: Vec<u8>,
    side: Vec<u8>,
    side_contexts: Vec<u8>,
    calm: Vec<bool>,
    escapes: Vec<u8>,
    words: Vec<u16>,
}

impl Default for DepthEncoder {
    fn default() -> Self {
        Self::new()
    }
}

impl DepthEncoder {
    /// An encoder with empty buffers.
    pub fn new() -> DepthEncoder {
        DepthEncoder {
            present: vec![false; 65536],
            level_of: vec![0u16; 65536]
                .into_boxed_slice()
                .try_into()
                .unwrap_or_else(|_| unreachable!()),
            levels: Vec::new(),
            rows: [Vec::new(), Vec::new()],
            symbols: Vec::new(),
            contexts: Vec::new(),
            side: Vec::new(),
            side_contexts: Vec::new(),
            calm: Vec::new(),
            escapes: Vec::new(),
            words: Vec::new(),
        }
    }

    /// Packs `samples` (row-major, 0 = invalid) into `out` (cleared first).
    pub fn encode(
        &mut self,
        samples: &[u16],
        width: u32,
        height: u32,
        mode: DepthEncoding,
        out: &mut Vec<u8>,
    ) -> Result<(), CodecError> {
        let expected = checked_len(width, height)?;
        if samples.len() != expected {
            return Err(CodecError::SizeMismatch {
                width,
                height,
                expected,
                got: samples.len(),
            });
        }
        out.clear();
        let half_step = match mode {
            DepthEncoding::Raw => {
                out.reserve(expected * 2);
                out.extend(samples.iter().flat_map(|s| s.to_le_bytes()));
                return Ok(());
            }
            DepthEncoding::Lossless => 0,
            DepthEncoding::Bounded { step: 0 } => return Err(CodecError::ZeroStep),
            DepthEncoding::Bounded { step } => step / 2,
        };
        out.push(FORMAT_TAG);
        if expected == 0 {
            return Ok(());
        }
        self.side.clear();
        self.build_levels(samples, half_step);
        self.write_validity(samples, width as usize);
        self.predict(samples, width as usize);
        self.side.extend_from_slice(&self.escapes);

        put_varint(out, self.side.len() as u32);
        let mut side_counts = [0u32; 256];
        for &b in &self.side {
            side_counts[b as usize] += 1;
        }
        let side_model = [rans::Model::from_counts(&side_counts)];
        side_model[0].write(out);
        self.side_contexts.clear();
        self.side_contexts.resize(self.side.len(), 0);
        rans::encode(
            &self.side,
            &self.side_contexts,
            &side_model,
            &mut self.words,
        );
        put_words(out, &self.words);

        // Four interleaved histograms: one would chain every increment of the same
        // (mostly zero) symbol through a store-to-load forward.
        let mut counts = [[[0u32; 256]; CONTEXTS]; 4];
        for (i, (&s, &c)) in self.symbols.iter().zip(&self.contexts).enumerate() {
            counts[i & 3][c as usize & (CONTEXTS - 1)][s as usize] += 1;
        }
        let mut merged = [[0u32; 256]; CONTEXTS];
        for part in &counts {
            for (m, p) in merged.iter_mut().zip(part) {
                for (a, b) in m.iter_mut().zip(p) {
                    *a += b;
                }
            }
        }
        let counts = merged;
        let models: Vec<rans::Model> = counts.iter().map(rans::Model::from_counts).collect();
        for m in &models {
            m.write(out);
        }
        rans::encode(&self.symbols, &self.contexts, &models, &mut self.words);
        put_words(out, &self.words);
        Ok(())
    }

    /// Groups the distinct valid values into levels at most `2 * half_step` wide and
    /// writes the level values to the side stream.
    fn build_levels(&mut self, samples: &[u16], half_step: u16) {
        // Plain byte stores: a read-modify-write bitset would chain through memory.
        self.present.fill(false);
        for &s in samples {
            self.present[s as usize] = true;
        }
        self.present[0] = false;
        self.levels.clear();
        let span = 2 * half_step as u32;
        let mut group: Option<(u32, u32)> = None;
        for (v, _) in self.present.iter().enumerate().filter(|(_, &p)| p) {
            let v = v as u32;
            {
                match group {
                    Some((lo, _)) if v - lo <= span => group = Some((lo, v)),
                    _ => {
                        if let Some((lo, hi)) = group {
                            self.levels.push(((lo + hi) / 2) as u16);
                        }
                        group = Some((v, v));
                    }
                }
                self.level_of[v as usize] = self.levels.len() as u16 + 1;
            }
        }
        if let Some((lo, hi)) = group {
            self.levels.push(((lo + hi) / 2) as u16);
        }
        put_varint(&mut self.side, self.levels.len() as u32);
        let mut prev = 0u16;
        for &l in &self.levels {
            put_varint(&mut self.side, (l - prev) as u32);
            prev = l;
        }
    }

    fn write_validity(&mut self, samples: &[u16], width: usize) {
        for row in samples.chunks_exact(width) {
            let mut x = 0;
            while x < width {
                let valid = row[x..].iter().take_while(|&&s| s != 0).count();
                x += valid;
                let invalid = row[x..].iter().take_while(|&&s| s == 0).count();
                x += invalid;
                put_varint(&mut self.side, valid as u32);
                if x < width || invalid > 0 {
                    put_varint(&mut self.side, invalid as u32);
                }
            }
        }
    }

    /// Fills `symbols`/`contexts` with the residual of every valid pixel and
    /// `escapes` with the varint tails of large ones.
    fn predict(&mut self, samples: &[u16], width: usize) {
        // Split borrows: pushing through `self` would make the compiler reload every
        // other buffer's pointer after each push.
        let DepthEncoder {
            level_of,
            rows: [prev, cur],
            symbols,
            contexts,
            calm,
            escapes,
            ..
        } = self;
        symbols.clear();
        contexts.clear();
        escapes.clear();
        prev.clear();
        prev.resize(width + 2, 0);
        cur.clear();
        cur.resize(width + 2, 0);
        calm.clear();
        calm.resize(width, true);
        let level_of: &[u16; 65536] = level_of;
        for row in samples.chunks_exact(width) {
            cur[0] = prev[1];
            let (mut a, mut b, mut c) = (cur[0], prev[1], prev[0]);
            let pixels = row
                .iter()
                .zip(&prev[2..])
                .zip(&mut cur[1..])
                .zip(calm.iter_mut());
            for (((&s, &d), cell), calm_x) in pixels {
                let pred = med(a, b, c);
                let ctx = context(b, c, d, *calm_x) as u8;
                (c, b) = (b, d);
                if s == 0 {
                    *cell = pred;
                    a = pred;
                    *calm_x = true;
                    continue;
                }
                let level = level_of[s as usize] as i32;
                *cell = level;
                a = level;
                let r = level - pred;
                let z = ((r << 1) ^ (r >> 31)) as u32;
                contexts.push(ctx);
                *calm_x = z == 0;
                if z >= ESCAPE {
                    symbols.push(ESCAPE as u8);
                    put_varint(escapes, z - ESCAPE);
                } else {
                    symbols.push(z as u8);
                }
            }
            cur[width + 1] = cur[width];
            std::mem::swap(prev, cur);
        }
    }
}

/// Unpacks depth images; keeps its buffers between frames.
#[derive(Debug, Clone)]
pub struct DepthDecoder {
    side: Vec<u8>,
    words: Vec<u16>,
    /// Level values by index (0 is unused: index 0 never decodes).
    levels: Box<[u16; 65536]>,
    runs: Vec<u32>,
    rows: [Vec<i32>; 2],
    tables: rans::Tables,
    calm: Vec<bool>,
    contexts: Vec<u8>,
    symbols: Vec<u8>,
}

impl Default for DepthDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl DepthDecoder {
    /// A decoder with empty buffers.
    pub fn new() -> DepthDecoder {
        DepthDecoder {
            side: Vec::new(),
            words: Vec::new(),
            levels: vec![0u16; 65536]
                .into_boxed_slice()
                .try_into()
                .unwrap_or_else(|_| unreachable!()),
            runs: Vec::new(),
            rows: [Vec::new(), Vec::new()],
            tables: rans::Tables::new(),
            calm: Vec::new(),
            contexts: Vec::new(),
            symbols: Vec::new(),
        }
    }

    /// Unpacks a payload into `out` (resized to width x height).
    pub fn decode(
        &mut self,
        data: &[u8],
        width: u32,
        height: u32,
        mode: DepthEncoding,
        out: &mut Vec<u16>,
    ) -> Result<(), CodecError> {
        let expected = checked_len(width, height)?;
        match mode {
            DepthEncoding::Raw => {
                if data.len() != expected * 2 {
                    return Err(CodecError::SizeMismatch {
                        width,
                        height,
                        expected,
                        got: data.len() / 2,
                    });
                }
                out.clear();
                out.extend(
                    data.chunks_exact(2)
                        .map(|c| u16::from_le_bytes([c[0], c[1]])),
                );
                Ok(())
            }
            DepthEncoding::Bounded { step: 0 } => Err(CodecError::ZeroStep),
            DepthEncoding::Lossless | DepthEncoding::Bounded { .. } => {
                out.clear();
                out.resize(expected, 0);
                if expected == 0 {
                    return if data == [FORMAT_TAG] {
                        Ok(())
                    } else {
                        Err(corrupt("empty image with a body"))
                    };
                }
                self.decode_packed(data, width as usize, out)
            }
        }
    }

    fn decode_packed(
        &mut self,
        data: &[u8],
        width: usize,
        out: &mut [u16],
    ) -> Result<(), CodecError> {
        let mut cur = Cursor::new(data);
        if cur.byte() != Some(FORMAT_TAG) {
            return Err(corrupt("bad format tag"));
        }
        // Side stream.
        let side_len = cur
            .varint()
            .ok_or_else(|| corrupt("truncated side length"))? as usize;
        // Every pixel costs at most a run byte and a 5-byte escape; more is forged.
        if side_len > 8 * out.len() + (1 << 20) {
            return Err(corrupt("side stream longer than any image needs"));
        }
        let side_model = rans::Model::read(&mut cur)
            .ok_or_else(|| corrupt("truncated side model"))?
            .map_err(|_| corrupt("bad side model"))?;
        self.tables.fill(0, &side_model);
        let n_words = cur
            .varint()
            .ok_or_else(|| corrupt("truncated side words"))? as usize;
        cur.words(n_words, &mut self.words)
            .ok_or_else(|| corrupt("truncated side words"))?;
        let mut dec =
            rans::Decoder::new(&self.words).map_err(|_| corrupt("side stream too short"))?;
        self.side.clear();
        self.side
            .extend((0..side_len).map(|_| dec.symbol(&self.tables, 0)));
        dec.finish()
            .map_err(|_| corrupt("side stream does not decode"))?;

        let mut side = Cursor::new(&self.side);
        let n_levels = side
            .varint()
            .ok_or_else(|| corrupt("truncated level count"))? as usize;
        if n_levels > 65535 {
            return Err(corrupt("more levels than u16 values"));
        }
        let mut value = 0u32;
        for i in 0..n_levels {
            let gap = side.varint().ok_or_else(|| corrupt("truncated levels"))?;
            value = value.saturating_add(gap);
            if gap == 0 || value > 65535 {
                return Err(corrupt("levels not strictly increasing in 1..=65535"));
            }
            self.levels[i + 1] = value as u16;
        }
        self.runs.clear();
        let height = out.len() / width;
        for _ in 0..height {
            let mut x = 0usize;
            loop {
                let valid = side
                    .varint()
                    .ok_or_else(|| corrupt("truncated validity runs"))?
                    as usize;
                x += valid;
                self.runs.push(valid as u32);
                if x > width {
                    return Err(corrupt("validity runs overflow the row"));
                }
                if x == width {
                    break;
                }
                let invalid = side
                    .varint()
                    .ok_or_else(|| corrupt("truncated validity runs"))?
                    as usize;
                x += invalid;
                self.runs.push(invalid as u32);
                if x > width {
                    return Err(corrupt("validity runs overflow the row"));
                }
                if x == width {
                    break;
                }
            }
        }

        // Residual stream.
        let mut models = Vec::with_capacity(CONTEXTS);
        for _ in 0..CONTEXTS {
            models.push(
                rans::Model::read(&mut cur)
                    .ok_or_else(|| corrupt("truncated residual model"))?
                    .map_err(|_| corrupt("bad residual model"))?,
            );
        }
        for (ctx, m) in models.iter().enumerate() {
            self.tables.fill(ctx, m);
        }
        let n_words = cur
            .varint()
            .ok_or_else(|| corrupt("truncated residual words"))? as usize;
        cur.words(n_words, &mut self.words)
            .ok_or_else(|| corrupt("truncated residual words"))?;
        if cur.pos != data.len() {
            return Err(corrupt("trailing bytes"));
        }
        let mut dec =
            rans::Decoder::new(&self.words).map_err(|_| corrupt("residual stream too short"))?;

        let DepthDecoder {
            rows: [prev, row],
            calm,
            contexts,
            symbols,
            tables,
            levels,
            runs,
            ..
        } = self;
        prev.clear();
        prev.resize(width + 2, 0);
        row.clear();
        row.resize(width + 2, 0);
        calm.clear();
        calm.resize(width, true);
        let levels: &[u16; 65536] = levels;
        let n_levels = n_levels as u32;
        let mut runs = runs.iter().map(|&r| r as usize);
        for out_row in out.chunks_exact_mut(width) {
            // Pass 1: every valid pixel's context depends on the row above only, so the
            // row's symbols decode in one batch, apart from the prediction chain.
            let row_runs = runs.clone();
            contexts.clear();
            let mut x = 0usize;
            while x < width {
                let valid = runs.next().ok_or_else(|| corrupt("validity runs"))?;
                let end = x + valid;
                let cells = prev[x..end + 2].windows(3).zip(&calm[x..end]);
                contexts.extend(cells.map(|(w, &calm_x)| context(w[1], w[0], w[2], calm_x) as u8));
                x = end;
                if x < width {
                    x += runs.next().ok_or_else(|| corrupt("validity runs"))?;
                }
            }
            symbols.clear();
            symbols.resize(contexts.len(), 0);
            dec.symbols(tables, contexts, symbols);

            // Pass 2: undo the prediction.
            let mut runs = row_runs;
            let mut syms = symbols.iter();
            let mut out_of_range = false;
            row[0] = prev[1];
            let mut x = 0usize;
            while x < width {
                let valid = runs.next().unwrap_or(0);
                let end = x + valid;
                // Neighbours ride in registers: reloading the pixel just stored would put
                // a store-to-load forward on the critical path of every pixel.
                let (mut a, mut b, mut c) = (row[x], prev[x + 1], prev[x]);
                let run = prev[x + 2..end + 2]
                    .iter()
                    .zip(&mut row[x + 1..end + 1])
                    .zip(&mut calm[x..end])
                    .zip(out_row[x..end].iter_mut().zip(&mut syms));
                for (((&d, cell), calm_x), (out_x, &sym)) in run {
                    let z = if sym as u32 == ESCAPE {
                        side.varint()
                            .and_then(|e| e.checked_add(ESCAPE))
                            .ok_or_else(|| corrupt("truncated escapes"))?
                    } else {
                        sym as u32
                    };
                    *calm_x = z == 0;
                    let r = (z >> 1) as i32 ^ -((z & 1) as i32);
                    let level = med(a, b, c).wrapping_add(r);
                    out_of_range |= (level as u32).wrapping_sub(1) >= n_levels;
                    *cell = level;
                    *out_x = levels[level as usize & 0xffff];
                    (a, c, b) = (level, b, d);
                }
                x = end;
                if x == width {
                    break;
                }
                let end = x + runs.next().unwrap_or(0);
                let mut a = row[x];
                for xi in x..end {
                    a = med(a, prev[xi + 1], prev[xi]);
                    row[xi + 1] = a;
                }
                calm[x..end].fill(true);
                out_row[x..end].fill(0);
                x = end;
            }
            if out_of_range {
                return Err(corrupt("level index out of range"));
            }
            row[width + 1] = row[width];
            std::mem::swap(prev, row);
        }
        dec.finish()
            .map_err(|_| corrupt("residual stream does not decode"))?;
        if side.pos != self.side.len() {
            return Err(corrupt("unused escapes"));
        }
        Ok(())
    }
}

thread_local! {
    static ENCODER: std::cell::RefCell<DepthEncoder> = std::cell::RefCell::new(DepthEncoder::new());
    static DECODER: std::cell::RefCell<DepthDecoder> = std::cell::RefCell::new(DepthDecoder::new());
}

/// Pack `samples` (row-major, 0 = invalid) into `out` (cleared first), with this
/// thread's [`DepthEncoder`] so repeated calls allocate nothing.
pub fn encode(
    samples: &[u16],
    width: u32,
    height: u32,
    mode: DepthEncoding,
    out: &mut Vec<u8>,
) -> Result<(), CodecError> {
    ENCODER.with(|e| match e.try_borrow_mut() {
        Ok(mut enc) => enc.encode(samples, width, height, mode, out),
        Err(_) => DepthEncoder::new().encode(samples, width, height, mode, out),
    })
}

/// Unpack a payload into `out` (resized to width x height), with this thread's
/// [`DepthDecoder`] so repeated calls allocate nothing.
pub fn decode(
    data: &[u8],
    width: u32,
    height: u32,
    mode: DepthEncoding,
    out: &mut Vec<u16>,
) -> Result<(), CodecError> {
    DECODER.with(|d| match d.try_borrow_mut() {
        Ok(mut dec) => dec.decode(data, width, height, mode, out),
        Err(_) => DepthDecoder::new().decode(data, width, height, mode, out),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 16-bit grayscale PNG from `../shared/data/real`, or `None` (with a message)
    /// when the data folder is absent.
    fn real_png(name: &str) -> Option<(u32, u32, Vec<u16>)> {
        let path = format!(
            "{}/../../shared/data/real/{name}",
            env!("CARGO_MANIFEST_DIR")
        );
        let Ok(file) = std::fs::File::open(&path) else {
            println!("skipping: {path} not present");
            return None;
        };
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        let samples = buf
            .chunks_exact(2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
            .collect();
        Some((info.width, info.height, samples))
    }

    const REAL: [&str; 2] = [
        "tum_depth_640x480_u16_5000perm.png",
        "redwood_00000_depth_640x480_u16_mm.png",
    ];

    fn round_trip(samples: &[u16], w: u32, h: u32, mode: DepthEncoding) -> (Vec<u8>, Vec<u16>) {
        let mut packed = Vec::new();
        encode(samples, w, h, mode, &mut packed).unwrap();
        let mut back = Vec::new();
        decode(&packed, w, h, mode, &mut back).unwrap();
        (packed, back)
    }

    /// Asserts the bounded-mode contract on every pixel; returns the largest error.
    fn assert_bounded(orig: &[u16], back: &[u16], step: u16) -> u16 {
        assert_eq!(orig.len(), back.len());
        let mut worst = 0;
        for (i, (&o, &b)) in orig.iter().zip(back).enumerate() {
            if o == 0 {
                assert_eq!(b, 0, "invalid pixel {i} became {b}");
            } else {
                assert_ne!(b, 0, "valid pixel {i} ({o}) became invalid");
                let err = o.abs_diff(b);
                assert!(
                    err <= step / 2,
                    "pixel {i}: {o} -> {b}, error {err} > {}",
                    step / 2
                );
                worst = worst.max(err);
            }
        }
        worst
    }

    /// Deterministic xorshift, so a failing random case reproduces.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
    }

    /// A synthetic 48x32 scene: a floor ramp, a box with a step edge, holes, noise
    /// and the extreme values 1 and 65535, so vectors exercise escapes and every branch.
    fn synthetic_scene() -> Vec<u16> {
        let mut rng = Rng(2024);
        let (w, h) = (48usize, 32usize);
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let r = rng.next();
                if r.is_multiple_of(17) || (x > 30 && y < 6) {
                    0
                } else if (10..20).contains(&x) && (8..20).contains(&y) {
                    800 + (r % 3) as u16
                } else if x == 47 && y == 31 {
                    65535
                } else if x == 0 && y == 31 {
                    1
                } else {
                    4000 - (y as u16) * 60 + (x as u16) * 3 + (r % 5) as u16
                }
            })
            .collect()
    }

    /// Writes (with `UPDATE_VECTORS=1`) or checks `schemas/vectors/depth_codec/<name>.bin`
    /// (the packed payload) and `.json` (encoding, size and the samples it decodes to),
    /// which `schemas/python/tests/test_depth.py` decodes with the Python codec.
    #[test]
    fn depth_codec_vectors_match_the_committed_files() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("vectors/depth_codec");
        let update = std::env::var_os("UPDATE_VECTORS").is_some_and(|v| v == "1");
        let scene = synthetic_scene();
        let cases: Vec<(&str, Vec<u16>, u32, u32, DepthEncoding)> = vec![
            (
                "lossless_scene",
                scene.clone(),
                48,
                32,
                DepthEncoding::Lossless,
            ),
            (
                "bounded_step5_scene",
                scene.clone(),
                48,
                32,
                DepthEncoding::Bounded { step: 5 },
            ),
            (
                "bounded_step1000_scene",
                scene,
                48,
                32,
                DepthEncoding::Bounded { step: 1000 },
            ),
            (
                "lossless_all_invalid",
                vec![0; 8 * 4],
                8,
                4,
                DepthEncoding::Lossless,
            ),
            (
                "lossless_one_pixel",
                vec![1234],
                1,
                1,
                DepthEncoding::Lossless,
            ),
            ("lossless_empty", vec![], 0, 0, DepthEncoding::Lossless),
        ];
        let mut stale = Vec::new();
        for (name, samples, w, h, mode) in cases {
            let (packed, back) = round_trip(&samples, w, h, mode);
            if let DepthEncoding::Bounded { step } = mode {
                assert_bounded(&samples, &back, step);
            }
            let json =
                serde_json::json!({ "encoding": mode, "width": w, "height": h, "samples": back });
            let json = serde_json::to_vec_pretty(&json).unwrap();
            for (file, bytes) in [
                (format!("{name}.bin"), packed),
                (format!("{name}.json"), json),
            ] {
                let path = dir.join(&file);
                if update {
                    std::fs::create_dir_all(&dir).unwrap();
                    std::fs::write(&path, &bytes).unwrap();
                } else if std::fs::read(&path).ok().as_deref() != Some(&bytes[..]) {
                    stale.push(file);
                }
            }
        }
        assert!(
            stale.is_empty(),
            "{stale:?} differ from what the codec writes now: regenerate with \
             `UPDATE_VECTORS=1 cargo test -p schemas --lib depth_codec_vectors`, review, run pytest"
        );
    }

    #[test]
    fn lossless_real_frames_round_trip_exactly_at_9x_or_better() {
        for name in REAL {
            let Some((w, h, samples)) = real_png(name) else {
                return;
            };
            let (packed, back) = round_trip(&samples, w, h, DepthEncoding::Lossless);
            assert_eq!(back, samples, "{name}");
            let ratio = (samples.len() * 2) as f64 / packed.len() as f64;
            println!("{name}: lossless {} bytes, {ratio:.2}x", packed.len());
            assert!(ratio >= 9.0, "{name}: lossless ratio {ratio:.2}");
        }
    }

    #[test]
    fn bounded_5mm_real_frames_stay_within_2_5mm_on_every_pixel_at_12x_or_better() {
        // 5 mm in each file's units: TUM stores 5000 per metre, Redwood millimetres.
        for (name, step) in [(REAL[0], 25), (REAL[1], 5)] {
            let Some((w, h, samples)) = real_png(name) else {
                return;
            };
            let mode = DepthEncoding::Bounded { step };
            let (packed, back) = round_trip(&samples, w, h, mode);
            let worst = assert_bounded(&samples, &back, step);
            let ratio = (samples.len() * 2) as f64 / packed.len() as f64;
            println!(
                "{name}: bounded step {step}: {} bytes, {ratio:.2}x, max error {worst}",
                packed.len()
            );
            assert!(ratio >= 12.0, "{name}: bounded ratio {ratio:.2}");
        }
    }

    #[test]
    fn extreme_values_keep_their_bound_for_every_step() {
        let samples = [
            0, 1, 2, 3, 65535, 65534, 0, 1500, 1502, 1499, 800, 812, 0, 2750, 65533, 7,
        ];
        for step in [1, 2, 3, 4, 5, 25, 1000, 65535] {
            let (_, back) = round_trip(&samples, 4, 4, DepthEncoding::Bounded { step });
            assert_bounded(&samples, &back, step);
        }
        let (_, back) = round_trip(&samples, 4, 4, DepthEncoding::Lossless);
        assert_eq!(back, samples);
    }

    #[test]
    fn random_images_of_odd_shapes_round_trip() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for (w, h) in [(1, 1), (1, 17), (17, 1), (3, 5), (64, 48), (640, 3)] {
            for sparsity in [0u64, 3, 50, 100] {
                let samples: Vec<u16> = (0..w * h)
                    .map(|_| {
                        let r = rng.next();
                        if r % 100 < sparsity {
                            0
                        } else {
                            (r >> 16) as u16
                        }
                    })
                    .collect();
                let (_, back) = round_trip(&samples, w, h, DepthEncoding::Lossless);
                assert_eq!(back, samples, "{w}x{h} sparsity {sparsity}");
                let (_, back) = round_trip(&samples, w, h, DepthEncoding::Bounded { step: 7 });
                assert_bounded(&samples, &back, 7);
            }
        }
    }

    #[test]
    fn empty_and_all_invalid_images_round_trip() {
        let (_, back) = round_trip(&[], 0, 0, DepthEncoding::Lossless);
        assert!(back.is_empty());
        let (packed, back) = round_trip(&[0; 640 * 480], 640, 480, DepthEncoding::Lossless);
        assert!(back.iter().all(|&s| s == 0));
        assert!(
            packed.len() < 1000,
            "{} bytes for an empty frame",
            packed.len()
        );
    }

    #[test]
    fn raw_mode_is_little_endian_samples() {
        let (packed, back) = round_trip(&[0x0102, 0], 2, 1, DepthEncoding::Raw);
        assert_eq!(packed, [2, 1, 0, 0]);
        assert_eq!(back, [0x0102, 0]);
    }

    #[test]
    fn wrong_sample_count_and_zero_step_are_refused() {
        let mut out = Vec::new();
        assert!(matches!(
            encode(&[1, 2, 3], 2, 2, DepthEncoding::Lossless, &mut out),
            Err(CodecError::SizeMismatch {
                expected: 4,
                got: 3,
                ..
            })
        ));
        assert_eq!(
            encode(&[1; 4], 2, 2, DepthEncoding::Bounded { step: 0 }, &mut out),
            Err(CodecError::ZeroStep)
        );
        let mut back = Vec::new();
        assert!(matches!(
            decode(&[0; 6], 2, 2, DepthEncoding::Raw, &mut back),
            Err(CodecError::SizeMismatch { .. })
        ));
        assert!(matches!(
            decode(
                &[FORMAT_TAG],
                1 << 16,
                1 << 16,
                DepthEncoding::Lossless,
                &mut back
            ),
            Err(CodecError::TooLarge { .. })
        ));
    }

    #[test]
    fn reused_encoder_and_decoder_give_the_same_bytes_as_fresh_ones() {
        let mut rng = Rng(42);
        let mut enc = DepthEncoder::new();
        let mut dec = DepthDecoder::new();
        for frame in 0..4 {
            let samples: Vec<u16> = (0..40 * 30)
                .map(|i| {
                    if rng.next().is_multiple_of(9) {
                        0
                    } else {
                        1000 + (i % 40) as u16 * frame
                    }
                })
                .collect();
            let mut reused = Vec::new();
            enc.encode(&samples, 40, 30, DepthEncoding::Lossless, &mut reused)
                .unwrap();
            let mut fresh = Vec::new();
            DepthEncoder::new()
                .encode(&samples, 40, 30, DepthEncoding::Lossless, &mut fresh)
                .unwrap();
            assert_eq!(reused, fresh);
            let mut back = Vec::new();
            dec.decode(&reused, 40, 30, DepthEncoding::Lossless, &mut back)
                .unwrap();
            assert_eq!(back, samples);
        }
    }

    #[test]
    fn every_truncation_of_a_payload_is_refused() {
        let samples: Vec<u16> = (0..32 * 24)
            .map(|i| {
                if i % 11 == 0 {
                    0
                } else {
                    900 + (i % 32) as u16 * 3 + (i / 32) as u16
                }
            })
            .collect();
        let (packed, _) = round_trip(&samples, 32, 24, DepthEncoding::Lossless);
        let mut back = Vec::new();
        for cut in 0..packed.len() {
            assert!(
                decode(&packed[..cut], 32, 24, DepthEncoding::Lossless, &mut back).is_err(),
                "cut at {cut}"
            );
        }
        let mut longer = packed.clone();
        longer.push(0);
        assert!(decode(&longer, 32, 24, DepthEncoding::Lossless, &mut back).is_err());
    }

    #[test]
    fn random_corruption_gives_an_error_or_an_image_never_a_panic() {
        let mut rng = Rng(7);
        let samples: Vec<u16> = (0..64 * 48)
            .map(|i| {
                if i % 13 < 2 {
                    0
                } else {
                    1200 + (i % 64) as u16 * 5
                }
            })
            .collect();
        let (packed, _) = round_trip(&samples, 64, 48, DepthEncoding::Bounded { step: 5 });
        let mut back = Vec::new();
        let mut refused = 0;
        for _ in 0..3000 {
            let mut bad = packed.clone();
            for _ in 0..1 + rng.next() % 4 {
                let i = rng.next() as usize % bad.len();
                bad[i] ^= 1 << (rng.next() % 8);
            }
            match decode(&bad, 64, 48, DepthEncoding::Bounded { step: 5 }, &mut back) {
                Err(_) => refused += 1,
                Ok(()) => assert_eq!(back.len(), samples.len()),
            }
        }
        // The end-state check of rANS catches nearly every flip.
        assert!(refused > 2900, "only {refused} of 3000 corruptions refused");
    }
}
