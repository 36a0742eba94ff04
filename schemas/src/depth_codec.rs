//! Depth image packing for [`DepthFrame`](crate::DepthFrame): raw, lossless, or
//! bounded-error. Each frame decodes on its own (no inter-frame state), so a lost
//! packet costs one frame, never a stream.
//!
//! The packed format, version 3 (both compressed modes share it; the decoder needs no
//! mode). It is shaped for speed on one core: one entropy-coded symbol per four pixels,
//! a predictor whose reconstruction is a running sum, and every quad of a row decoded
//! in one batch (`cargo bench -p schemas --bench depth_codec`).
//!
//! 1. **Levels.** Structured-light cameras (Kinect, Xtion) measure disparity, so a
//!    frame holds only a few hundred distinct depths. The distinct valid samples are
//!    grouped into levels, sorted: lossless keeps one level per value; bounded mode
//!    greedily merges values spanning at most `2 * (step / 2)` units into one level
//!    whose value is the middle of its span, so every sample is within `step / 2`
//!    (at most as many levels as quantising to `step`, and never more error).
//!    Pixels are then coded as level indices (1-based), which are proportional to
//!    disparity: neighbours on a surface differ by 0 or 1 index.
//! 2. **Validity.** Invalid (0) pixels are sent as per-row run lengths, never as
//!    depths, so they cannot become valid and valid pixels cannot become 0.
//! 3. **Prediction.** Each pixel's level is predicted by its left neighbour's; a row's
//!    first pixel by the first pixel of the row above (level 1 for the first row). An
//!    invalid pixel carries the level left of it (residual 0). The residual becomes a
//!    2-bit code: 0, +1, -1, or "exception". LOCO-I's median predictor (Weinberger,
//!    Seroussi, Sapiro 2000, which format 1 used) saves about a tenth of the bits on
//!    the TUM frame and nothing on the Redwood one, but its reconstruction is a chain
//!    of four dependent operations per pixel, while left prediction's is one addition
//!    per four pixels (the running sums of each quad's codes are a table).
//! 4. **Entropy coding.** Four horizontally adjacent pixels' codes (pixel `i` at bits
//!    `2i`) form one 8-bit quad symbol, coded with rANS (the private `rans` module) under 8 contexts
//!    from the row above: the activity of the quad above (its codes' sizes, 0 / 1 for
//!    +-1 / 2 for an exception, summed and capped at 3) times 2, plus 1 if the quad
//!    above-right is not all zero. Codes of invalid pixels (and of the padding past a
//!    row's end) are 0. A quad with no valid pixel is all zero and takes a ninth
//!    context, whose model (implied, not sent) gives symbol 0 every slot: it costs no
//!    bits and leaves the rANS state as it is, but takes its turn among the
//!    interleaved states. Version 2 skipped such quads, which made the decoder gather
//!    a row's coded quads before and scatter their symbols after the rANS batch; that
//!    was about a tenth of its time.
//!    Exceptions go in pixel order to their own rANS stream as `zigzag(residual) - 3`
//!    bytes, 255 meaning "the rest follows as a varint in the side stream". Level
//!    values, run lengths and the models go in a side stream coded with one more rANS
//!    model over bytes.
//!
//! Layout: `FORMAT_TAG`, varint side length, side model, then three word streams (each
//! a varint word count and u16 LE words): side, quads, exceptions. The side stream
//! holds: level count, first level, level gaps; per row, alternating valid/invalid run
//! lengths summing to the width; the 8 quad models; the exception model; the exception
//! count; the escapes in pixel order.

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

/// First byte of a compressed payload: format version 3. Versions 1 (0xD1, one MED
/// residual symbol per pixel) and 2 (0xD2, quads with no valid pixel not coded) are
/// refused as unknown formats.
const FORMAT_TAG: u8 = 0xD3;
/// Pixels per coded symbol.
const QUAD: usize = 4;
/// Quad contexts: 4 activity classes of the quad above x quad above-right all zero or not.
const CONTEXTS: usize = 8;
/// Pixel code: the residual is in the exception stream.
const EXCEPTION: u8 = 3;
/// Exception symbol meaning "the rest of `zigzag - 3` follows as a varint".
const ESCAPE: u32 = 255;
/// Smallest zigzag residual that needs an exception (0, +1 and -1 have codes).
const FIRST_EXCEPTION: u32 = 3;

/// Per quad symbol: the running sums of its four codes' residuals (exceptions count as
/// 0; quads with exceptions never take the path that uses this).
const RUNNING_SUM: [[i32; QUAD]; 256] = {
    let mut table = [[0i32; QUAD]; 256];
    let mut s = 0;
    while s < 256 {
        let mut acc = 0;
        let mut i = 0;
        while i < QUAD {
            acc += match (s >> (2 * i)) & 3 {
                1 => 1,
                2 => -1,
                _ => 0,
            };
            table[s][i] = acc;
            i += 1;
        }
        s += 1;
    }
    table
};

/// [`RUNNING_SUM`] modulo 2^16, to add to a level index's low 16 bits.
const WRAPPING_SUM: [[u16; QUAD]; 256] = {
    let mut table = [[0u16; QUAD]; 256];
    let mut s = 0;
    while s < 256 {
        let mut i = 0;
        while i < QUAD {
            table[s][i] = RUNNING_SUM[s][i] as u16;
            i += 1;
        }
        s += 1;
    }
    table
};

/// Per quad symbol and pixel: how many of the pixels up to it are exceptions.
const EXCEPTIONS_UPTO: [[u8; QUAD]; 256] = {
    let mut table = [[0u8; QUAD]; 256];
    let mut s = 0;
    while s < 256 {
        let mut count = 0;
        let mut i = 0;
        while i < QUAD {
            count += ((s >> (2 * i)) & 3 == 3) as u8;
            table[s][i] = count;
            i += 1;
        }
        s += 1;
    }
    table
};

/// Per quad symbol: how many of its pixels are exceptions.
const EXCEPTIONS_IN: [u8; 256] = {
    let mut table = [0u8; 256];
    let mut s = 0;
    while s < 256 {
        let mut i = 0;
        while i < QUAD {
            table[s] += ((s >> (2 * i)) & 3 == 3) as u8;
            i += 1;
        }
        s += 1;
    }
    table
};

/// Per validity mask of a quad (bit i = pixel i valid): what keeps each pixel's depth,
/// all ones for a valid pixel and zero for an invalid one.
const KEEP: [[u16; QUAD]; 16] = {
    let mut table = [[0u16; QUAD]; 16];
    let mut m = 0;
    while m < 16 {
        let mut i = 0;
        while i < QUAD {
            if (m >> i) & 1 != 0 {
                table[m][i] = u16::MAX;
            }
            i += 1;
        }
        m += 1;
    }
    table
};

/// Validity mask of a quad whose pixels are all valid.
const ALL_VALID: u8 = (1 << QUAD) - 1;

/// Context of a quad with no valid pixel, one past the coded ones: its symbol is 0.
const UNCODED: u8 = CONTEXTS as u8;

/// `context`, or [`UNCODED`] for a quad with no valid pixel. Masks rather than a
/// select, which the compiler does not vectorise here.
#[inline(always)]
fn context_or_uncoded(mask: u8, context: u8) -> u8 {
    let coded = ((mask != 0) as u8).wrapping_neg();
    (context & coded) | (UNCODED & !coded)
}

/// Counts of a model whose only symbol is 0: it has every slot, so coding it costs
/// nothing and leaves the rANS state unchanged.
const CERTAIN_ZERO: [u32; 256] = {
    let mut counts = [0u32; 256];
    counts[0] = 1;
    counts
};

/// Activity class of a quad symbol: the sum of its codes' sizes (0 for a zero
/// residual, 1 for +-1, 2 for an exception) capped at 3. Bit arithmetic rather than a
/// table, so that a row's worth vectorises.
#[inline(always)]
fn activity(sym: u8) -> u8 {
    // Per 2-bit code: 1 if it is not zero, plus 1 if it is an exception.
    let sizes = ((sym | sym >> 1) & 0x55) + (sym & sym >> 1 & 0x55);
    let pairs = (sizes & 0x33) + (sizes >> 2 & 0x33);
    ((pairs & 0x0f) + (pairs >> 4)).min(3)
}

/// The code bits of a quad's valid pixels (bit i of `mask` = pixel i valid): those of
/// invalid pixels must be zero.
#[inline(always)]
fn valid_code_bits(mask: u8) -> u8 {
    let spread = (mask & 1) | (mask & 2) << 1 | (mask & 4) << 2 | (mask & 8) << 3;
    spread * 3
}

/// Context of a quad from the two quads above it (row above, same and next column).
#[inline(always)]
fn quad_context(above: u8, above_right: u8) -> u8 {
    activity(above) * 2 + (above_right != 0) as u8
}

#[inline(always)]
fn zigzag(r: i32) -> u32 {
    ((r << 1) ^ (r >> 31)) as u32
}

#[inline(always)]
fn unzigzag(z: u32) -> i32 {
    (z >> 1) as i32 ^ -((z & 1) as i32)
}

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
                return if shift == 28 && b > 0x0f { None } else { Some(v) };
            }
        }
        None
    }

    fn byte(&mut self) -> Option<u8> {
        let b = *self.bytes.get(self.pos)?;
        self.pos += 1;
        Some(b)
    }

    fn words(&mut self, out: &mut Vec<u16>) -> Option<()> {
        let count = self.varint()? as usize;
        let end = self.pos.checked_add(count.checked_mul(2)?)?;
        let raw = self.bytes.get(self.pos..end)?;
        out.clear();
        out.extend(raw.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]])));
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

/// Grows `zeros` (all zero) to at least `len` and returns that many: the contexts of a
/// single-model stream.
fn zeros(zeros: &mut Vec<u8>, len: usize) -> &[u8] {
    if zeros.len() < len {
        zeros.resize(len, 0);
    }
    &zeros[..len]
}

/// A model counted from `symbols`.
fn byte_model(symbols: &[u8]) -> rans::Model {
    let mut counts = [0u32; 256];
    for &b in symbols {
        counts[b as usize] += 1;
    }
    rans::Model::from_counts(&counts)
}

/// Packs depth images; keeps its buffers between frames so a stream allocates once.
#[derive(Debug, Clone)]
pub struct DepthEncoder {
    present: Box<[bool; 65536]>,
    level_of: Box<[u16; 65536]>,
    level_values: Vec<u16>,
    /// The current row's levels (after the first pixel's prediction) and residual
    /// codes, padded to whole quads.
    levels: Vec<u16>,
    codes: Vec<u8>,
    /// Quad symbols of the row above, plus a zero past the end.
    above: Vec<u8>,
    masks: Vec<u8>,
    /// The current row's quads that hold an exception.
    exception_quads: Vec<usize>,
    /// The current row's samples, padded with invalid pixels to whole quads.
    padded: Vec<u16>,
    symbols: Vec<u8>,
    contexts: Vec<u8>,
    exceptions: Vec<u8>,
    escapes: Vec<u8>,
    side: Vec<u8>,
    zeros: Vec<u8>,
    words: Vec<u16>,
    rans: rans::Encoder,
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
            present: vec![false; 65536].into_boxed_slice().try_into().unwrap_or_else(|_| unreachable!()),
            level_of: vec![0u16; 65536].into_boxed_slice().try_into().unwrap_or_else(|_| unreachable!()),
            level_values: Vec::new(),
            levels: Vec::new(),
            codes: Vec::new(),
            above: Vec::new(),
            masks: Vec::new(),
            exception_quads: Vec::new(),
            padded: Vec::new(),
            symbols: Vec::new(),
            contexts: Vec::new(),
            exceptions: Vec::new(),
            escapes: Vec::new(),
            side: Vec::new(),
            zeros: Vec::new(),
            words: Vec::new(),
            rans: rans::Encoder::default(),
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
            return Err(CodecError::SizeMismatch { width, height, expected, got: samples.len() });
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
        self.code_quads(samples, width as usize);

        // Four interleaved histograms: one would chain every increment of the same
        // (mostly all-zero) symbol through a store-to-load forward.
        // Uncoded quads' symbols are counted too (in their own context) rather than
        // skipped with a branch.
        let mut parts = [[0u32; 16 * 256]; 4];
        let (symbols, contexts) = (self.symbols.chunks_exact(4), self.contexts.chunks_exact(4));
        let (symbols_left, contexts_left) = (symbols.remainder(), contexts.remainder());
        for (s, c) in symbols.zip(contexts) {
            for k in 0..4 {
                parts[k][(c[k] as usize & 15) << 8 | s[k] as usize] += 1;
            }
        }
        for (&s, &c) in symbols_left.iter().zip(contexts_left) {
            parts[0][(c as usize & 15) << 8 | s as usize] += 1;
        }
        let mut counts = [[0u32; 256]; 16];
        for part in &parts {
            for (sum, p) in counts.iter_mut().zip(part.chunks_exact(256)) {
                for (a, b) in sum.iter_mut().zip(p) {
                    *a += b;
                }
            }
        }
        let mut quad_models: Vec<rans::Model> = counts[..CONTEXTS].iter().map(rans::Model::from_counts).collect();
        for m in &quad_models {
            m.write(&mut self.side);
        }
        quad_models.push(rans::Model::from_counts(&CERTAIN_ZERO));
        let exception_model = byte_model(&self.exceptions);
        exception_model.write(&mut self.side);
        put_varint(&mut self.side, self.exceptions.len() as u32);
        self.side.extend_from_slice(&self.escapes);

        put_varint(out, self.side.len() as u32);
        let side_model = byte_model(&self.side);
        side_model.write(out);
        let side_contexts = zeros(&mut self.zeros, self.side.len());
        self.rans.encode(&self.side, side_contexts, &[side_model], &mut self.words);
        put_words(out, &self.words);
        self.rans.encode(&self.symbols, &self.contexts, &quad_models, &mut self.words);
        put_words(out, &self.words);
        let exception_contexts = zeros(&mut self.zeros, self.exceptions.len());
        self.rans.encode(&self.exceptions, exception_contexts, &[exception_model], &mut self.words);
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
        self.level_values.clear();
        let span = 2 * half_step as u32;
        let mut group: Option<(u32, u32)> = None;
        for (v, _) in self.present.iter().enumerate().filter(|(_, &p)| p) {
            let v = v as u32;
            match group {
                Some((lo, _)) if v - lo <= span => group = Some((lo, v)),
                _ => {
                    if let Some((lo, hi)) = group {
                        self.level_values.push(((lo + hi) / 2) as u16);
                    }
                    group = Some((v, v));
                }
            }
            self.level_of[v as usize] = self.level_values.len() as u16 + 1;
        }
        if let Some((lo, hi)) = group {
            self.level_values.push(((lo + hi) / 2) as u16);
        }
        put_varint(&mut self.side, self.level_values.len() as u32);
        let mut prev = 0u16;
        for &l in &self.level_values {
            put_varint(&mut self.side, (l - prev) as u32);
            prev = l;
        }
    }

    /// Writes each row's validity runs to the side stream; fills `symbols`/`contexts`
    /// with every quad's symbol and context ([`UNCODED`] for quads with no valid
    /// pixel), `exceptions` with the exception bytes and `escapes` with their varints.
    fn code_quads(&mut self, samples: &[u16], width: usize) {
        // Split borrows: pushing through `self` would make the compiler reload every
        // other buffer's pointer after each push.
        let DepthEncoder {
            level_of,
            levels,
            codes,
            above,
            masks,
            exception_quads,
            padded,
            symbols,
            contexts,
            exceptions,
            escapes,
            side,
            ..
        } = self;
        let n_quads = width.div_ceil(QUAD);
        // Levels lead with the prediction of the row's first pixel.
        levels.clear();
        levels.resize(n_quads * QUAD + 1, 0);
        codes.clear();
        codes.resize(n_quads * QUAD, 0);
        above.clear();
        above.resize(n_quads + 1, 0);
        masks.clear();
        masks.resize(n_quads, 0);
        exception_quads.clear();
        exception_quads.resize(n_quads, 0);
        padded.clear();
        padded.resize(n_quads * QUAD, 0);
        let n_total = n_quads * (samples.len() / width);
        symbols.clear();
        symbols.resize(n_total, 0);
        contexts.clear();
        contexts.resize(n_total, 0);
        exceptions.clear();
        escapes.clear();
        let level_of: &[u16; 65536] = level_of;
        // The level of the first pixel of the row above predicts the first pixel; 1
        // (the first level) before the first row, so every prediction is a level.
        let mut row_start = 1u16;
        let quad_rows = symbols.chunks_exact_mut(n_quads).zip(contexts.chunks_exact_mut(n_quads));
        for (row, (row_symbols, row_contexts)) in samples.chunks_exact(width).zip(quad_rows) {
            padded[..width].copy_from_slice(row);
            // Each step is a pass of its own over the row, so that all but the level
            // lookup and the carrying over holes have nothing chained from pixel to
            // pixel, and the compiler vectorises them.
            levels[0] = row_start;
            for (lv, &s) in levels[1..].iter_mut().zip(padded.iter()) {
                // Index 0 is never a level: invalid pixels get 0 here.
                *lv = level_of[s as usize];
            }
            for (mask, px) in masks.iter_mut().zip(padded.as_chunks::<QUAD>().0) {
                *mask = (px[0] != 0) as u8
                    | ((px[1] != 0) as u8) << 1
                    | ((px[2] != 0) as u8) << 2
                    | ((px[3] != 0) as u8) << 3;
            }
            write_runs(side, masks, width);
            carry_over_holes(levels, masks);
            let pairs = levels[1..].iter().zip(levels.iter());
            for (code, (&level, &left)) in codes.iter_mut().zip(pairs) {
                // In u16, eight pixels to a vector register. Levels and their
                // predictions lie in 1..=65535, so their difference is +-1 exactly when
                // it is modulo 2^16.
                let d = level.wrapping_sub(left);
                *code = (d == 1) as u8 | ((d == u16::MAX) as u8) << 1 | ((d.wrapping_add(1) > 2) as u8 * EXCEPTION);
            }
            for (sym, c) in row_symbols.iter_mut().zip(codes.as_chunks::<QUAD>().0) {
                // Code i (< 4) moves from bit 8i to bit 2i.
                let w = u32::from_le_bytes(*c);
                *sym = (w | w >> 6 | w >> 12 | w >> 18) as u8;
            }
            let context_cells = row_contexts.iter_mut().zip(masks.iter());
            for ((ctx, &mask), (&up, &up_right)) in context_cells.zip(above.iter().zip(&above[1..])) {
                *ctx = context_or_uncoded(mask, quad_context(up, up_right));
            }
            // Exceptions are a few per cent of pixels: their quads are listed without
            // a branch, then visited.
            let mut n_exception_quads = 0usize;
            for (q, &sym) in row_symbols.iter().enumerate() {
                exception_quads[n_exception_quads] = q;
                n_exception_quads += (EXCEPTIONS_IN[sym as usize] != 0) as usize;
            }
            for &q in &exception_quads[..n_exception_quads] {
                for x in q * QUAD..(q + 1) * QUAD {
                    if codes[x] == EXCEPTION {
                        let e = zigzag(levels[x + 1] as i32 - levels[x] as i32) - FIRST_EXCEPTION;
                        if e >= ESCAPE {
                            exceptions.push(ESCAPE as u8);
                            put_varint(escapes, e - ESCAPE);
                        } else {
                            exceptions.push(e as u8);
                        }
                    }
                }
            }
            row_start = levels[1];
            above[..n_quads].copy_from_slice(row_symbols);
        }
    }
}

/// Gives every invalid pixel of a row (0 in `levels`, after the row's leading
/// prediction) the level left of it, so its residual is 0.
fn carry_over_holes(levels: &mut [u16], masks: &[u8]) {
    let (start, pixels) = levels.split_at_mut(1);
    let mut left = start[0];
    for (&mask, lv) in masks.iter().zip(pixels.as_chunks_mut::<QUAD>().0) {
        if mask == ALL_VALID {
            left = lv[QUAD - 1];
        } else if mask == 0 {
            lv.fill(left);
        } else {
            for l in lv {
                // A select: which pixels of a ragged hole edge are valid is noise.
                left = if *l == 0 { left } else { *l };
                *l = left;
            }
        }
    }
}

/// Appends a row's validity runs, from its quads' masks: alternating valid and
/// invalid run lengths, starting with a valid one (maybe 0), up to the row's width.
fn write_runs(side: &mut Vec<u8>, masks: &[u8], width: usize) {
    let (mut valid, mut run) = (true, 0u32);
    for (q, &mask) in masks.iter().enumerate() {
        let pixels = QUAD.min(width - q * QUAD);
        // Whole quads that continue the run: most of a row.
        if pixels == QUAD && mask == if valid { ALL_VALID } else { 0 } {
            run += QUAD as u32;
            continue;
        }
        for i in 0..pixels {
            if ((mask >> i) & 1 != 0) != valid {
                put_varint(side, run);
                (valid, run) = (!valid, 0);
            }
            run += 1;
        }
    }
    put_varint(side, run);
}

/// Unpacks depth images; keeps its buffers between frames.
#[derive(Debug, Clone)]
pub struct DepthDecoder {
    side: Vec<u8>,
    side_words: Vec<u16>,
    quad_words: Vec<u16>,
    exception_words: Vec<u16>,
    /// Level values by index; index 0, which no level has, gives 0 (an invalid pixel).
    levels: Box<[u16; 65536]>,
    /// Validity mask of every quad of the image, row by row.
    masks: Vec<u8>,
    /// Invalid pixels per row.
    invalid: Vec<usize>,
    /// Per quad of the row above: activity class times 2, and whether it is not all
    /// zero (plus a zero past the row's end).
    above: [Vec<u8>; 2],
    /// One row's quad contexts, which decode into its quad symbols in place.
    quads: Vec<u8>,
    exceptions: Vec<u8>,
    /// Residuals of the exceptions, in pixel order, then `QUAD` zeros.
    residuals: Vec<i32>,
    /// One row's level indices, padded to whole quads (0 for invalid pixels).
    indices: Vec<u16>,
    tables: rans::Tables,
}

impl Default for DepthDecoder {
    fn default() -> Self {
        Self::new()
    }
}

/// The residual stream's models, read from the side stream.
struct Models {
    quads: Vec<rans::Model>,
    exceptions: rans::Model,
}

impl DepthDecoder {
    /// A decoder with empty buffers.
    pub fn new() -> DepthDecoder {
        DepthDecoder {
            side: Vec::new(),
            side_words: Vec::new(),
            quad_words: Vec::new(),
            exception_words: Vec::new(),
            levels: vec![0u16; 65536].into_boxed_slice().try_into().unwrap_or_else(|_| unreachable!()),
            masks: Vec::new(),
            invalid: Vec::new(),
            above: [Vec::new(), Vec::new()],
            quads: Vec::new(),
            exceptions: Vec::new(),
            residuals: Vec::new(),
            indices: Vec::new(),
            tables: DepthDecoder::tables(),
        }
    }

    /// Decoding tables with the uncoded quads' model in place: the frame's models
    /// never overwrite it.
    fn tables() -> rans::Tables {
        let mut tables = rans::Tables::new();
        tables.fill(UNCODED as usize, &rans::Model::from_counts(&CERTAIN_ZERO));
        tables
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
                    return Err(CodecError::SizeMismatch { width, height, expected, got: data.len() / 2 });
                }
                out.clear();
                out.extend(data.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]])));
                Ok(())
            }
            DepthEncoding::Bounded { step: 0 } => Err(CodecError::ZeroStep),
            DepthEncoding::Lossless | DepthEncoding::Bounded { .. } => {
                // Decoding writes every pixel: zeroing the buffer first would be a
                // wasted pass over it.
                out.resize(expected, 0);
                if expected == 0 {
                    return if data == [FORMAT_TAG] { Ok(()) } else { Err(corrupt("empty image with a body")) };
                }
                self.decode_packed(data, width as usize, out)
            }
        }
    }

    fn decode_packed(&mut self, data: &[u8], width: usize, out: &mut [u16]) -> Result<(), CodecError> {
        // A side stream of one repeated byte (its model certain) is never longer than this:
        // models, counts and runs make any real side stream several distinct bytes.
        const CERTAIN_SIDE_MAX: usize = 4096;
        let mut cur = Cursor::new(data);
        if cur.byte() != Some(FORMAT_TAG) {
            return Err(corrupt("unknown format tag (not a version 3 payload)"));
        }
        let side_len = cur.varint().ok_or_else(|| corrupt("truncated side length"))? as usize;
        // Every pixel costs at most a run byte and a 5-byte escape; more is forged.
        if side_len > 8 * out.len() + (1 << 20) {
            return Err(corrupt("side stream longer than any image needs"));
        }
        let side_model = rans::Model::read(&mut cur)
            .ok_or_else(|| corrupt("truncated side model"))?
            .map_err(|_| corrupt("bad side model"))?;
        cur.words(&mut self.side_words).ok_or_else(|| corrupt("truncated side words"))?;
        // A length the words cannot carry is forged, and would cost a second of decoding
        // nothing for a 4096x4096 frame claimed in 27 bytes (docs/fuzzing.md).
        let carried = side_model.most_symbols(self.side_words.len()).unwrap_or(CERTAIN_SIDE_MAX);
        if side_len > carried {
            return Err(corrupt("side stream longer than its words can carry"));
        }
        cur.words(&mut self.quad_words).ok_or_else(|| corrupt("truncated quad words"))?;
        cur.words(&mut self.exception_words).ok_or_else(|| corrupt("truncated exception words"))?;
        if cur.pos != data.len() {
            return Err(corrupt("trailing bytes"));
        }

        self.tables.fill(0, &side_model);
        let mut dec = rans::Decoder::new(&self.side_words).map_err(|_| corrupt("side stream too short"))?;
        // Context 0 for every byte, decoded in place.
        self.side.clear();
        self.side.resize(side_len, 0);
        dec.symbols(&self.tables, &mut self.side);
        dec.finish().map_err(|_| corrupt("side stream does not decode"))?;

        let side = std::mem::take(&mut self.side);
        let result = self.decode_body(&side, width, out);
        self.side = side;
        result
    }

    /// Everything after the side stream's entropy decoding: `side` is its bytes.
    fn decode_body(&mut self, side: &[u8], width: usize, out: &mut [u16]) -> Result<(), CodecError> {
        let mut side = Cursor::new(side);
        let n_levels = self.read_levels(&mut side)?;
        self.read_validity(&mut side, width, out.len() / width)?;
        let models = read_models(&mut side)?;
        self.decode_exceptions(&models.exceptions, &mut side, out.len())?;
        if side.pos != side.bytes.len() {
            return Err(corrupt("unused side bytes"));
        }
        self.decode_rows(&models.quads, width, n_levels, out)
    }

    /// Reads the level values into `levels`; returns their count.
    fn read_levels(&mut self, side: &mut Cursor) -> Result<u32, CodecError> {
        let n_levels = side.varint().ok_or_else(|| corrupt("truncated level count"))? as usize;
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
        Ok(n_levels as u32)
    }

    /// Reads the validity runs into the quads' masks.
    fn read_validity(&mut self, side: &mut Cursor, width: usize, height: usize) -> Result<(), CodecError> {
        let n_quads = width.div_ceil(QUAD);
        self.masks.clear();
        self.masks.resize(n_quads * height, 0);
        self.invalid.clear();
        self.invalid.resize(height, 0);
        let mut run = || -> Result<usize, CodecError> {
            side.varint().map(|r| r as usize).ok_or_else(|| corrupt("truncated validity runs"))
        };
        for (masks, invalid) in self.masks.chunks_exact_mut(n_quads).zip(&mut self.invalid) {
            let mut x = 0usize;
            let mut valid = 0usize;
            loop {
                let end = x + run()?;
                if end > width {
                    return Err(corrupt("validity runs overflow the row"));
                }
                mark_valid(masks, x, end);
                valid += end - x;
                x = end;
                if x == width {
                    break;
                }
                x += run()?;
                if x > width {
                    return Err(corrupt("validity runs overflow the row"));
                }
                if x == width {
                    break;
                }
            }
            *invalid = width - valid;
        }
        Ok(())
    }

    /// Decodes the exceptions' residuals into `residuals`: their count and escapes
    /// from `side`, their bytes from the exception stream.
    fn decode_exceptions(&mut self, model: &rans::Model, side: &mut Cursor, n_pixels: usize) -> Result<(), CodecError> {
        let n_exceptions = side.varint().ok_or_else(|| corrupt("truncated exception count"))? as usize;
        if n_exceptions > n_pixels {
            return Err(corrupt("more exceptions than pixels"));
        }
        self.tables.fill(0, model);
        let mut dec = rans::Decoder::new(&self.exception_words).map_err(|_| corrupt("exception stream too short"))?;
        self.exceptions.clear();
        self.exceptions.resize(n_exceptions, 0);
        dec.symbols(&self.tables, &mut self.exceptions);
        dec.finish().map_err(|_| corrupt("exception stream does not decode"))?;
        self.residuals.clear();
        for &e in &self.exceptions {
            let e = if e as u32 == ESCAPE {
                side.varint().and_then(|rest| rest.checked_add(ESCAPE)).ok_or_else(|| corrupt("truncated escapes"))?
            } else {
                e as u32
            };
            let z = e.checked_add(FIRST_EXCEPTION).ok_or_else(|| corrupt("exception out of range"))?;
            self.residuals.push(unzigzag(z));
        }
        // Padding, so that a quad's exceptions are always read as a whole quad's worth.
        self.residuals.extend([0; QUAD]);
        Ok(())
    }

    /// Decodes the quad symbols and undoes the prediction, row by row, into `out`.
    fn decode_rows(
        &mut self,
        models: &[rans::Model],
        width: usize,
        n_levels: u32,
        out: &mut [u16],
    ) -> Result<(), CodecError> {
        for (ctx, m) in models.iter().enumerate() {
            self.tables.fill(ctx, m);
        }
        let n_quads = width.div_ceil(QUAD);
        let DepthDecoder { quad_words, masks, invalid, above, quads, tables, levels, residuals, indices, .. } = self;
        // Per quad of the row above: its activity class times 2 and whether it is
        // not all zero (one more, zero, past the row's end), from which the contexts
        // are sums.
        let [activities, nonzero] = above;
        activities.clear();
        activities.resize(n_quads, 0);
        nonzero.clear();
        nonzero.resize(n_quads + 1, 0);
        quads.clear();
        quads.resize(n_quads, 0);
        indices.clear();
        indices.resize(n_quads * QUAD, 0);
        let mut dec = rans::Decoder::new(quad_words).map_err(|_| corrupt("quad stream too short"))?;
        let levels: &[u16; 65536] = levels;
        let mut pending = &residuals[..];
        // Sign bit set when a level leaves 1..=n_levels or an exception is missing.
        let mut status = 0i32;
        // Code bits on invalid pixels.
        let mut codes_on_invalid = 0u8;
        let n_levels_u16 = n_levels as u16;
        let mut row_start = 1i32;
        let rows = out.chunks_exact_mut(width).zip(masks.chunks_exact(n_quads)).zip(invalid.iter());
        for ((out_row, row_masks), &row_invalid) in rows {
            if row_invalid == width {
                // No valid pixel (a frame's top and bottom margins): every quad is
                // uncoded, symbol 0 at no cost, and the first level carries on.
                dec.skip_certain(n_quads);
                activities.fill(0);
                nonzero.fill(0);
                out_row.fill(0);
                continue;
            }
            // Contexts depend on the row above only, so a row's symbols decode in one
            // batch with the rANS lanes overlapping. The passes around it are byte
            // arithmetic with nothing chained from quad to quad: vectorised.
            let contexts = quads.iter_mut().zip(row_masks).zip(activities.iter().zip(&nonzero[1..]));
            for ((ctx, &mask), (&act, &right)) in contexts {
                *ctx = context_or_uncoded(mask, act + right);
            }
            // Uncoded quads at the row's ends (a frame's side margins) are symbol 0 at
            // no cost: skipped, turning the lanes as decoding them would.
            let lead = row_masks.iter().take_while(|&&m| m == 0).count();
            let trail = row_masks[lead..].iter().rev().take_while(|&&m| m == 0).count();
            let coded = lead..n_quads - trail;
            quads[..lead].fill(0);
            quads[coded.end..].fill(0);
            dec.skip_certain(lead);
            dec.symbols(tables, &mut quads[coded.clone()]);
            dec.skip_certain(trail);
            let above_out = activities.iter_mut().zip(nonzero.iter_mut());
            for ((&sym, &mask), (act, nz)) in quads.iter().zip(row_masks).zip(above_out) {
                codes_on_invalid |= sym & !valid_code_bits(mask);
                *act = activity(sym) * 2;
                *nz = (sym != 0) as u8;
            }
            let (first, row_status) = row_levels(quads, row_masks, row_start, &mut pending, n_levels, indices);
            row_start = first;
            status |= row_status;
            // A valid pixel's level is in 1..=n_levels (the quads with exceptions have
            // checked theirs), an invalid pixel's index is 0: every index is at most
            // n_levels and the row has as many zeros as invalid pixels.
            let row_indices = &indices[..width];
            // In 16 bits, eight pixels to a vector register, a block at a time.
            let (mut highest, mut zeros) = (0u16, 0usize);
            for block in row_indices.chunks(u16::MAX as usize) {
                let (block_highest, block_zeros) =
                    block.iter().fold((0u16, 0u16), |(m, z), &i| (m.max(i), z + (i == 0) as u16));
                highest = highest.max(block_highest);
                zeros += block_zeros as usize;
            }
            status |= -((highest > n_levels_u16 || zeros != row_invalid) as i32);
            for (o, &i) in out_row.iter_mut().zip(row_indices) {
                *o = levels[i as usize];
            }
        }
        dec.finish().map_err(|_| corrupt("quad stream does not decode"))?;
        if status < 0 || codes_on_invalid != 0 {
            return Err(corrupt("level index out of range or codes on invalid pixels"));
        }
        if pending.len() > QUAD {
            return Err(corrupt("unused exceptions"));
        }
        Ok(())
    }
}

/// Sets the mask bits of pixels `start..end` of a row.
fn mark_valid(masks: &mut [u8], start: usize, end: usize) {
    if start == end {
        return;
    }
    let (first, last) = (start / QUAD, (end - 1) / QUAD);
    // Pixels from `start % QUAD` on in the first quad, up to `end` in the last.
    let head = ALL_VALID & (ALL_VALID << (start % QUAD));
    let tail = ALL_VALID >> (QUAD - 1 - (end - 1) % QUAD);
    if first == last {
        masks[first] |= head & tail;
    } else {
        masks[first] |= head;
        masks[first + 1..last].fill(ALL_VALID);
        masks[last] |= tail;
    }
}

/// Reads the quad and exception models from the side stream.
fn read_models(side: &mut Cursor) -> Result<Models, CodecError> {
    let mut read =
        || rans::Model::read(side).ok_or_else(|| corrupt("truncated model"))?.map_err(|_| corrupt("bad model"));
    let quads = (0..CONTEXTS).map(|_| read()).collect::<Result<_, _>>()?;
    let exceptions = read()?;
    Ok(Models { quads, exceptions })
}

/// Undoes the prediction for one row: fills `indices` (whole quads) with each pixel's
/// level index, 0 for invalid pixels, from the quads' symbols and validity masks, the
/// level predicting the first pixel and the exceptions' residuals (`pending`, advanced
/// past the row's; it ends with `QUAD` zeros that no quad takes). Returns the first
/// pixel's level, which predicts the next row's, and a status whose sign bit is set if
/// a quad with exceptions has a valid pixel out of `1..=n_levels` or misses an
/// exception. The other quads' levels are the caller's to check: each is the left one
/// plus at most 1 either way, so the first out of range is 0 or `n_levels + 1`,
/// whatever came before.
fn row_levels(
    quads: &[u8],
    masks: &[u8],
    row_start: i32,
    pending: &mut &[i32],
    n_levels: u32,
    indices: &mut [u16],
) -> (i32, i32) {
    let mut status = 0i32;
    let mut quad = |sym: u8, mask: u8, left: i32, idx: &mut [u16; QUAD]| -> (i32, i32) {
        if EXCEPTIONS_IN[sym as usize] != 0 {
            let (head, last, quad_status) = exception_quad(sym, mask, left, pending, n_levels, idx);
            status |= quad_status;
            return (head, last);
        }
        // Each level is the left one plus a tabled running sum, so the chain from quad
        // to quad is one addition; an invalid pixel has code 0 and carries the level
        // left of it.
        let (sums, keep) = (&WRAPPING_SUM[sym as usize], &KEEP[mask as usize & 15]);
        for i in 0..QUAD {
            idx[i] = (left as u16).wrapping_add(sums[i]) & keep[i];
        }
        (left.wrapping_add(RUNNING_SUM[sym as usize][0]), left.wrapping_add(RUNNING_SUM[sym as usize][QUAD - 1]))
    };
    let mut cells = quads.iter().zip(masks).zip(indices.as_chunks_mut::<QUAD>().0);
    let Some(((&sym, &mask), idx)) = cells.next() else {
        return (row_start, status);
    };
    let (first, mut left) = quad(sym, mask, row_start, idx);
    for ((&sym, &mask), idx) in cells {
        left = quad(sym, mask, left, idx).1;
    }
    (first, status)
}

/// Undoes the prediction for a quad holding exceptions, taking their residuals from
/// `pending`; returns its first and last levels (an invalid pixel carries the level
/// left of it) and a status whose sign bit is set on a missing exception or a valid
/// pixel's level out of `1..=n_levels`. Not inlined: a tenth of quads at most come
/// here, and inlined it would crowd the common path's registers.
#[inline(never)]
fn exception_quad(
    sym: u8,
    mask: u8,
    left: i32,
    pending: &mut &[i32],
    n_levels: u32,
    idx: &mut [u16; QUAD],
) -> (i32, i32, i32) {
    let n = EXCEPTIONS_IN[sym as usize] as usize;
    let left_over = pending.len().saturating_sub(QUAD);
    let status = -((left_over < n) as i32);
    // Pixel i's level adds to the running sum of the quad's other codes the residuals
    // of its exceptions up to i: a prefix of the pending ones (those past the quad's
    // are read but never used).
    let &[r0, r1, r2, r3] = pending.first_chunk::<QUAD>().unwrap_or(&[0; QUAD]);
    *pending = &pending[n.min(left_over)..];
    let (p2, p3) = (r0.wrapping_add(r1), r0.wrapping_add(r1).wrapping_add(r2));
    let prefix = [0, r0, p2, p3, p3.wrapping_add(r3), 0, 0, 0];
    let (sums, upto, keep) = (&RUNNING_SUM[sym as usize], &EXCEPTIONS_UPTO[sym as usize], &KEEP[mask as usize & 15]);
    let level = |i: usize| left.wrapping_add(sums[i]).wrapping_add(prefix[upto[i] as usize & 7]);
    let levels = [level(0), level(1), level(2), level(3)];
    let mut out_of_range = false;
    for i in 0..QUAD {
        out_of_range |= ((mask >> i) & 1 != 0) & ((levels[i] as u32).wrapping_sub(1) >= n_levels);
        idx[i] = levels[i] as u16 & keep[i];
    }
    (levels[0], levels[QUAD - 1], status | -(out_of_range as i32))
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
pub fn decode(data: &[u8], width: u32, height: u32, mode: DepthEncoding, out: &mut Vec<u16>) -> Result<(), CodecError> {
    DECODER.with(|d| match d.try_borrow_mut() {
        Ok(mut dec) => dec.decode(data, width, height, mode, out),
        Err(_) => DepthDecoder::new().decode(data, width, height, mode, out),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 16-bit grayscale PNG from the repository's `tests/data/real/` (see its README).
    fn real_png(name: &str) -> (u32, u32, Vec<u16>) {
        let path = format!("{}/../tests/data/real/{name}", env!("CARGO_MANIFEST_DIR"));
        let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("{path} (part of the checkout): {e}"));
        let mut reader = png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        let samples = buf.chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]])).collect();
        (info.width, info.height, samples)
    }

    const REAL: [&str; 2] = ["tum_depth_640x480_u16_5000perm.png", "redwood_00000_depth_640x480_u16_mm.png"];

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
                assert!(err <= step / 2, "pixel {i}: {o} -> {b}, error {err} > {}", step / 2);
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
            ("lossless_scene", scene.clone(), 48, 32, DepthEncoding::Lossless),
            ("bounded_step5_scene", scene.clone(), 48, 32, DepthEncoding::Bounded { step: 5 }),
            ("bounded_step1000_scene", scene, 48, 32, DepthEncoding::Bounded { step: 1000 }),
            ("lossless_all_invalid", vec![0; 8 * 4], 8, 4, DepthEncoding::Lossless),
            ("lossless_one_pixel", vec![1234], 1, 1, DepthEncoding::Lossless),
            ("lossless_empty", vec![], 0, 0, DepthEncoding::Lossless),
        ];
        let mut stale = Vec::new();
        for (name, samples, w, h, mode) in cases {
            let (packed, back) = round_trip(&samples, w, h, mode);
            if let DepthEncoding::Bounded { step } = mode {
                assert_bounded(&samples, &back, step);
            }
            let json = serde_json::json!({ "encoding": mode, "width": w, "height": h, "samples": back });
            let json = serde_json::to_vec_pretty(&json).unwrap();
            for (file, bytes) in [(format!("{name}.bin"), packed), (format!("{name}.json"), json)] {
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
            let (w, h, samples) = real_png(name);
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
            let (w, h, samples) = real_png(name);
            let mode = DepthEncoding::Bounded { step };
            let (packed, back) = round_trip(&samples, w, h, mode);
            let worst = assert_bounded(&samples, &back, step);
            let ratio = (samples.len() * 2) as f64 / packed.len() as f64;
            println!("{name}: bounded step {step}: {} bytes, {ratio:.2}x, max error {worst}", packed.len());
            assert!(ratio >= 12.0, "{name}: bounded ratio {ratio:.2}");
        }
    }

    #[test]
    fn extreme_values_keep_their_bound_for_every_step() {
        let samples = [0, 1, 2, 3, 65535, 65534, 0, 1500, 1502, 1499, 800, 812, 0, 2750, 65533, 7];
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
        assert!(packed.len() < 1000, "{} bytes for an empty frame", packed.len());
    }

    #[test]
    fn rows_with_no_valid_pixel_and_empty_row_ends_round_trip() {
        // 9 and 13 columns: 3 and 4 quads a row, so skipping a row leaves the rANS
        // lanes turned by 3 and by 0; the empty rows come first, between and last, and
        // other rows start or end with quads of invalid pixels (1 or 2 of them).
        let mut rng = Rng(5);
        for w in [9usize, 13] {
            let invalid = |x: usize, y: usize| {
                [0, 4, 5, 9].contains(&y)
                    || (y == 2 && x < 4)
                    || (y == 3 && x >= 8)
                    || (y == 6 && x < 8)
                    || (y == 7 && (x < 4 || x >= w - 1))
            };
            let samples: Vec<u16> =
                (0..w * 10).map(|i| if invalid(i % w, i / w) { 0 } else { 1500 + (rng.next() % 40) as u16 }).collect();
            let (_, back) = round_trip(&samples, w as u32, 10, DepthEncoding::Lossless);
            assert_eq!(back, samples, "{w} columns");
        }
    }

    #[test]
    fn activity_and_valid_code_bits_match_their_definitions_for_every_quad() {
        for sym in 0..=255u8 {
            let codes = (0..QUAD).map(|i| (sym >> (2 * i)) & 3);
            let sizes: u8 = codes.map(|c| [0, 1, 1, 2][c as usize]).sum();
            assert_eq!(activity(sym), sizes.min(3), "symbol {sym:#010b}");
        }
        for mask in 0..16u8 {
            let bits = (0..QUAD).filter(|i| (mask >> i) & 1 != 0).fold(0u8, |b, i| b | 3 << (2 * i));
            assert_eq!(valid_code_bits(mask), bits, "mask {mask:#06b}");
        }
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
            Err(CodecError::SizeMismatch { expected: 4, got: 3, .. })
        ));
        assert_eq!(encode(&[1; 4], 2, 2, DepthEncoding::Bounded { step: 0 }, &mut out), Err(CodecError::ZeroStep));
        let mut back = Vec::new();
        assert!(matches!(decode(&[0; 6], 2, 2, DepthEncoding::Raw, &mut back), Err(CodecError::SizeMismatch { .. })));
        assert!(matches!(
            decode(&[FORMAT_TAG], 1 << 16, 1 << 16, DepthEncoding::Lossless, &mut back),
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
                .map(|i| if rng.next().is_multiple_of(9) { 0 } else { 1000 + (i % 40) as u16 * frame })
                .collect();
            let mut reused = Vec::new();
            enc.encode(&samples, 40, 30, DepthEncoding::Lossless, &mut reused).unwrap();
            let mut fresh = Vec::new();
            DepthEncoder::new().encode(&samples, 40, 30, DepthEncoding::Lossless, &mut fresh).unwrap();
            assert_eq!(reused, fresh);
            let mut back = Vec::new();
            dec.decode(&reused, 40, 30, DepthEncoding::Lossless, &mut back).unwrap();
            assert_eq!(back, samples);
        }
    }

    #[test]
    fn every_truncation_of_a_payload_is_refused() {
        let samples: Vec<u16> =
            (0..32 * 24).map(|i| if i % 11 == 0 { 0 } else { 900 + (i % 32) as u16 * 3 + (i / 32) as u16 }).collect();
        let (packed, _) = round_trip(&samples, 32, 24, DepthEncoding::Lossless);
        let mut back = Vec::new();
        for cut in 0..packed.len() {
            assert!(decode(&packed[..cut], 32, 24, DepthEncoding::Lossless, &mut back).is_err(), "cut at {cut}");
        }
        let mut longer = packed.clone();
        longer.push(0);
        assert!(decode(&longer, 32, 24, DepthEncoding::Lossless, &mut back).is_err());
    }

    #[test]
    fn version_1_and_2_payloads_are_refused_as_an_unknown_format() {
        let mut back = Vec::new();
        // Version 2's tag on a payload of this version (whose rANS lanes it would
        // take in another order), and the tag of the per-pixel MED format, version 1.
        let samples = [1000, 1001, 0, 0];
        let mut packed = Vec::new();
        encode(&samples, 2, 2, DepthEncoding::Lossless, &mut packed).unwrap();
        for tag in [0xD2, 0xD1] {
            packed[0] = tag;
            assert_eq!(
                decode(&packed, 2, 2, DepthEncoding::Lossless, &mut back),
                Err(CodecError::Corrupt("unknown format tag (not a version 3 payload)".to_string()))
            );
        }
    }

    #[test]
    fn payload_full_of_exceptions_and_escapes_refuses_every_cut_and_survives_every_flip() {
        // Random depths: nearly every pixel is an exception, many need escapes, and a
        // few holes make partly valid quads; 13 columns leave a cut quad per row.
        let mut rng = Rng(99);
        let samples: Vec<u16> = (0..13 * 9)
            .map(|_| {
                let r = rng.next();
                if r.is_multiple_of(7) {
                    0
                } else {
                    (r >> 20) as u16 | 1
                }
            })
            .collect();
        let (packed, back) = round_trip(&samples, 13, 9, DepthEncoding::Lossless);
        assert_eq!(back, samples);
        let mut out = Vec::new();
        for cut in 0..packed.len() {
            assert!(decode(&packed[..cut], 13, 9, DepthEncoding::Lossless, &mut out).is_err(), "cut at {cut}");
        }
        let mut refused = 0;
        for i in 0..packed.len() {
            for bit in 0..8 {
                let mut bad = packed.clone();
                bad[i] ^= 1 << bit;
                match decode(&bad, 13, 9, DepthEncoding::Lossless, &mut out) {
                    Err(_) => refused += 1,
                    Ok(()) => assert_eq!(out.len(), samples.len()),
                }
            }
        }
        assert!(refused * 100 >= packed.len() * 8 * 95, "only {refused} of {} flips refused", packed.len() * 8);
    }

    #[test]
    fn random_corruption_gives_an_error_or_an_image_never_a_panic() {
        let mut rng = Rng(7);
        let samples: Vec<u16> = (0..64 * 48).map(|i| if i % 13 < 2 { 0 } else { 1200 + (i % 64) as u16 * 5 }).collect();
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
