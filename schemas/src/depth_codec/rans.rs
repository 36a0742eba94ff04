//! Range asymmetric numeral systems (rANS, Duda 2013, "Asymmetric numeral systems",
//! arXiv:1311.2540, section 4) with per-context static models: four interleaved 32-bit states,
//! 16-bit renormalisation and 10-bit probabilities, so that a context's decoding table
//! takes 5 KiB and the busy ones stay in the L1 cache (with 12 bits a frame took about
//! 4 % longer to decode, for 0.5 to 0.8 % fewer bytes).
//!
//! Symbols are encoded last to first so the decoder reads forward. The encoder starts
//! from `STATE_LOW`; a decoder that does not end there, or runs out of words, has been
//! fed a corrupt stream.

/// Probability resolution: every model's frequencies sum to `1 << PROB_BITS`.
pub const PROB_BITS: u32 = 10;
const PROB_SCALE: u32 = 1 << PROB_BITS;
const SLOT_MASK: u32 = PROB_SCALE - 1;
/// Lower bound of the normalised state interval `[STATE_LOW, STATE_LOW << 16)`.
const STATE_LOW: u32 = 1 << 16;

/// Why a stream or a model does not decode.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RansError {
    /// A model's frequencies do not sum to the probability scale.
    BadModel,
    /// The stream ended early, or left the state where the encoder did not start.
    BadStream,
}

/// Normalised frequencies of one context: `freq[s]` out of `1 << PROB_BITS`.
#[derive(Debug, Clone)]
pub struct Model {
    freq: [u16; 256],
}

/// A symbol's frequency, start and `reciprocal(freq)` (so encoding multiplies
/// instead of dividing).
#[derive(Debug, Clone, Copy, Default)]
struct EncodeSlot {
    rcp: u64,
    freq: u32,
    start: u32,
}

/// Shift of [`quotient`]'s product.
const RECIPROCAL_SHIFT: u32 = 32 + PROB_BITS;

/// `m = ceil(2^(32+P) / f)` for `P = PROB_BITS`, with `quotient(x, m) == x / f` for
/// every `1 <= f <= 2^P` and `x < f * 2^(32-P)`, the states the encoder divides (it
/// spills a word first otherwise). `m` exceeds `2^(32+P) / f` by less than 1, so
/// `x * m / 2^(32+P)` exceeds `x / f` by less than `x / 2^(32+P) < f / 2^(2P) <= 1 / f`
/// for `f < 2^P` (exact for the power of two `2^P`), while a non-integer `x / f` lies
/// at least `1 / f` below the next integer. The product is at most
/// `(f * 2^(32-P) - 1) * (2^(32+P) / f + 1) < 2^64 + f * 2^(32-P) - 2^(32+P) / f`,
/// which fits in 64 bits for `f <= 2^P`.
const fn reciprocal(f: u32) -> u64 {
    (1u64 << RECIPROCAL_SHIFT).div_ceil(f as u64)
}

/// `reciprocal(f)` for every frequency (and 0 for 0, which no encoded symbol has), so
/// that a model's encoding slots cost no division.
const RECIPROCALS: [u64; PROB_SCALE as usize + 1] = {
    let mut table = [0u64; PROB_SCALE as usize + 1];
    let mut f = 1;
    while f <= PROB_SCALE {
        table[f as usize] = reciprocal(f);
        f += 1;
    }
    table
};

#[inline(always)]
fn quotient(x: u32, rcp: u64) -> u32 {
    ((x as u64 * rcp) >> RECIPROCAL_SHIFT) as u32
}

impl Model {
    /// A model from raw symbol counts: every counted symbol gets at least one slot.
    /// All-zero counts give an empty model (no symbol can be coded with it).
    pub fn from_counts(counts: &[u32; 256]) -> Model {
        let total: u64 = counts.iter().map(|&c| c as u64).sum();
        let mut freq = [0u16; 256];
        if total == 0 {
            return Model::from_freq(freq);
        }
        let mut sum: i64 = 0;
        for (f, &c) in freq.iter_mut().zip(counts) {
            if c > 0 {
                *f = ((c as u64 * PROB_SCALE as u64 + total / 2) / total).max(1) as u16;
                sum += *f as i64;
            }
        }
        // Rounding leaves the sum a little off the scale: settle the difference on the
        // most frequent symbols, never taking one below a single slot.
        while sum != PROB_SCALE as i64 {
            let (best, _) = freq
                .iter()
                .enumerate()
                .filter(|(_, &f)| sum < PROB_SCALE as i64 || f > 1)
                .max_by_key(|(i, &f)| (f, std::cmp::Reverse(*i)))
                .unwrap_or((0, &0));
            let step = (PROB_SCALE as i64 - sum).clamp(-(freq[best] as i64 - 1), PROB_SCALE as i64);
            freq[best] = (freq[best] as i64 + step) as u16;
            sum += step;
        }
        Model::from_freq(freq)
    }

    fn from_freq(freq: [u16; 256]) -> Model {
        Model { freq }
    }

    /// What encoding each symbol needs, in one place so a symbol costs one cache line.
    fn slots(&self) -> [EncodeSlot; 256] {
        let mut slots = [EncodeSlot::default(); 256];
        let mut start = 0u32;
        for (slot, &f) in slots.iter_mut().zip(&self.freq) {
            let f = f as u32;
            *slot = EncodeSlot { rcp: RECIPROCALS[f as usize], freq: f, start };
            start += f;
        }
        slots
    }

    /// The most symbols `words` 16-bit words of a stream can carry under this model:
    /// each costs at least log2(scale / largest frequency) bits, and the words hold all
    /// the stream's information (the lanes' states included). `None` when one symbol is
    /// certain: it costs nothing, so the words bound nothing.
    pub fn most_symbols(&self, words: usize) -> Option<usize> {
        let largest = self.freq.iter().copied().max().unwrap_or(0).max(1) as f64;
        if largest >= PROB_SCALE as f64 {
            return None;
        }
        let bits_each = (PROB_SCALE as f64 / largest).log2();
        Some(((16 * words) as f64 / bits_each).ceil() as usize + 64)
    }

    /// Appends the model: the count of symbols up to the last used one, then each
    /// frequency as a varint.
    pub fn write(&self, out: &mut Vec<u8>) {
        let used = self.freq.iter().rposition(|&f| f > 0).map_or(0, |i| i + 1);
        super::put_varint(out, used as u32);
        for &f in &self.freq[..used] {
            super::put_varint(out, f as u32);
        }
    }

    /// Reads a model written by [`Model::write`]; empty models are allowed.
    pub fn read(cursor: &mut super::Cursor) -> Option<Result<Model, RansError>> {
        let used = cursor.varint()? as usize;
        if used > 256 {
            return Some(Err(RansError::BadModel));
        }
        let mut freq = [0u16; 256];
        let mut sum = 0u32;
        for f in &mut freq[..used] {
            let v = cursor.varint()?;
            if v > PROB_SCALE {
                return Some(Err(RansError::BadModel));
            }
            *f = v as u16;
            sum += v;
        }
        if sum != PROB_SCALE && sum != 0 {
            return Some(Err(RansError::BadModel));
        }
        Some(Ok(Model::from_freq(freq)))
    }

    fn is_empty(&self) -> bool {
        self.freq.iter().all(|&f| f == 0)
    }
}

/// Encodes symbol streams, keeping its models' encoding slots between calls.
#[derive(Debug, Clone, Default)]
pub struct Encoder {
    slots: Vec<[EncodeSlot; 256]>,
}

impl Encoder {
    /// Encodes `symbols[i]` with `models[contexts[i]]` into 16-bit words (cleared
    /// first), in the order the decoder reads them. [`LANES`] states take turns (symbol
    /// `i` uses state `i % LANES`) so the decoder's table lookups overlap. Every symbol
    /// must have a non-zero frequency in its model (true when the models were counted
    /// from these symbols).
    pub fn encode(&mut self, symbols: &[u8], contexts: &[u8], models: &[Model], words: &mut Vec<u16>) {
        self.slots.clear();
        self.slots.extend(models.iter().map(Model::slots));
        encode_with(symbols, contexts, &self.slots, words);
    }
}

fn encode_with(symbols: &[u8], contexts: &[u8], slots: &[[EncodeSlot; 256]], words: &mut Vec<u16>) {
    // At most one word per symbol, then the states: written by index, so whether a
    // symbol spills a word is a select rather than a branch the predictor loses.
    words.clear();
    words.resize(symbols.len() + 2 * LANES, 0);
    let mut n = 0usize;
    let mut states = [STATE_LOW; LANES];
    // Per context, its symbols' slots: a lookup with no bounds check.
    let by_context: [&[EncodeSlot; 256]; MAX_CONTEXTS] =
        std::array::from_fn(|c| &slots[c.min(slots.len().saturating_sub(1))]);
    let mut put = |x: u32, s: u8, c: u8| -> u32 {
        let e = by_context[c as usize & (MAX_CONTEXTS - 1)][s as usize];
        let f = e.freq;
        debug_assert!(f > 0, "symbol {s} not in model {c}");
        // Whether `x >= ((STATE_LOW >> PROB_BITS) << 16) * f`: that bound is
        // `f << (32 - PROB_BITS)`.
        let spill = x >> (32 - PROB_BITS) >= f;
        words[n] = x as u16;
        n += spill as usize;
        // Never 0: a state at least `STATE_LOW` keeps at least 16 after a spill.
        let kept = if spill { x >> 16 } else { x };
        let q = quotient(kept, e.rcp);
        (q << PROB_BITS) + (kept - q * f) + e.start
    };
    // Symbol i belongs to lane i % LANES; last to first, whole groups of lanes with the
    // states in registers.
    let len = symbols.len().min(contexts.len());
    let (groups, _) = symbols[..len].as_chunks::<LANES>();
    let whole = groups.len() * LANES;
    for i in (whole..len).rev() {
        states[i % LANES] = put(states[i % LANES], symbols[i], contexts[i]);
    }
    for (s, c) in groups.iter().zip(contexts[..whole].as_chunks::<LANES>().0).rev() {
        for lane in (0..LANES).rev() {
            states[lane] = put(states[lane], s[lane], c[lane]);
        }
    }
    for x in states.iter().rev() {
        words[n] = *x as u16;
        words[n + 1] = (*x >> 16) as u16;
        n += 2;
    }
    words.truncate(n);
    words.reverse();
}

/// Interleaved rANS states.
pub const LANES: usize = 4;

/// Number of models a [`Tables`] holds (more than the codec uses, so that the table
/// has `1 << 16` slots).
pub const MAX_CONTEXTS: usize = 1 << (16 - PROB_BITS);
/// Every 16-bit slot index is in the tables, so a lookup needs no bounds check.
const TABLE_LEN: usize = MAX_CONTEXTS << PROB_BITS;
const _: () = assert!(TABLE_LEN == 1 << 16);

/// Decoding tables of up to [`MAX_CONTEXTS`] models, per context and slot: the symbol,
/// and its frequency and the slot's offset in the symbol's range packed
/// `freq | off << 16`. Apart, so that a step reads each field with a plain load instead
/// of unpacking it from one word.
#[derive(Debug, Clone)]
pub struct Tables {
    steps: Box<[u32; TABLE_LEN]>,
    symbols: Box<[u8; TABLE_LEN]>,
}

impl Tables {
    /// Tables with every context empty.
    pub fn new() -> Tables {
        let steps = vec![1u32; TABLE_LEN].into_boxed_slice().try_into().unwrap_or_else(|_| unreachable!());
        let symbols = vec![0u8; TABLE_LEN].into_boxed_slice().try_into().unwrap_or_else(|_| unreachable!());
        Tables { steps, symbols }
    }

    /// Rebuilds context `ctx`'s table from `model`. An empty model's slots decode to
    /// symbol 0 with a frequency of 1, which shrinks the state until [`Decoder::finish`]
    /// refuses the stream.
    pub fn fill(&mut self, ctx: usize, model: &Model) {
        let range = ctx << PROB_BITS..(ctx + 1) << PROB_BITS;
        let (steps, symbols) = (&mut self.steps[range.clone()], &mut self.symbols[range]);
        if model.is_empty() {
            steps.fill(1);
            symbols.fill(0);
            return;
        }
        let mut slot = 0usize;
        for s in 0..256usize {
            let f = model.freq[s] as u32;
            for off in 0..f {
                steps[slot] = f | off << 16;
                symbols[slot] = s as u8;
                slot += 1;
            }
        }
    }
}

/// Reads symbols from a word stream written by [`encode`].
pub struct Decoder<'a> {
    words: &'a [u16],
    pos: usize,
    /// States in the order they decode: `lanes[0]` serves the next symbol.
    lanes: [u32; LANES],
}

impl<'a> Decoder<'a> {
    /// Starts decoding; a stream shorter than its state words is corrupt.
    pub fn new(words: &'a [u16]) -> Result<Decoder<'a>, RansError> {
        if words.len() < 2 * LANES {
            return Err(RansError::BadStream);
        }
        let mut lanes = [0u32; LANES];
        for (x, w) in lanes.iter_mut().zip(words.chunks_exact(2)) {
            *x = (w[0] as u32) << 16 | w[1] as u32;
        }
        Ok(Decoder { words, pos: 2 * LANES, lanes })
    }

    /// Decodes one symbol per byte of `buf`, which holds the symbols' contexts and
    /// gets the symbols in their place (one buffer, so one register fewer in the loop).
    /// The states live in registers for the whole batch, so each lane's lookup chain
    /// overlaps the others' instead of passing through memory.
    pub fn symbols(&mut self, tables: &Tables, buf: &mut [u8]) {
        if self.pos + buf.len() <= self.words.len() {
            // A symbol takes at most one word: the batch stays within the stream.
            self.batch(tables, buf, |words, pos| words[pos] as u32);
        } else {
            // Past the end reads zeros; `finish` then sees `pos` beyond the stream.
            self.batch(tables, buf, |words, pos| words.get(pos).map_or(0, |&w| w as u32));
        }
    }

    #[inline(always)]
    fn batch(&mut self, tables: &Tables, buf: &mut [u8], word_at: impl Fn(&[u16], usize) -> u32) {
        let words = self.words;
        let (steps, symbols) = (&*tables.steps, &*tables.symbols);
        let mut pos = self.pos;
        let mut lanes = self.lanes;
        let mut step = |x: u32, ctx: &mut u8| -> u32 {
            let slot = ((*ctx as u32) << PROB_BITS | (x & SLOT_MASK)) as u16 as usize;
            let e = steps[slot];
            *ctx = symbols[slot];
            let next = (e & 0xffff) * (x >> PROB_BITS) + (e >> 16);
            // A select, not a branch, for whether the lane takes a word: a coin toss
            // the predictor loses.
            let renorm = next < STATE_LOW;
            let word = word_at(words, pos);
            pos += renorm as usize;
            if renorm {
                next << 16 | word
            } else {
                next
            }
        };
        let (groups, rest) = buf.as_chunks_mut::<LANES>();
        for group in groups {
            for (x, ctx) in lanes.iter_mut().zip(group) {
                *x = step(*x, ctx);
            }
        }
        for ctx in rest {
            let next = step(lanes[0], ctx);
            for i in 1..LANES {
                lanes[i - 1] = lanes[i];
            }
            lanes[LANES - 1] = next;
        }
        self.lanes = lanes;
        self.pos = pos;
    }

    /// Passes over `n` symbols of a model whose only symbol has every slot: decoding
    /// such a symbol reads nothing and leaves its state as it is, so all that changes
    /// is which lane serves the next symbol.
    pub fn skip_certain(&mut self, n: usize) {
        self.lanes.rotate_left(n % LANES);
    }

    /// Checks the stream ended where the encoder began: every word used, every state
    /// back at its start value.
    pub fn finish(self) -> Result<(), RansError> {
        if self.pos != self.words.len() || self.lanes.iter().any(|&x| x != STATE_LOW) {
            return Err(RansError::BadStream);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(symbols: &[u8], contexts: &[u8], n_ctx: usize) -> usize {
        let mut counts = vec![[0u32; 256]; n_ctx];
        for (&s, &c) in symbols.iter().zip(contexts) {
            counts[c as usize][s as usize] += 1;
        }
        let models: Vec<Model> = counts.iter().map(Model::from_counts).collect();
        let mut words = Vec::new();
        Encoder::default().encode(symbols, contexts, &models, &mut words);
        let mut tables = Tables::new();
        for (c, m) in models.iter().enumerate() {
            tables.fill(c, m);
        }
        let mut dec = Decoder::new(&words).unwrap();
        // In two batches, so a batch ending mid-round of the lanes is covered too.
        let mut back = contexts.to_vec();
        let cut = symbols.len() / 3;
        let (first, second) = back.split_at_mut(cut);
        dec.symbols(&tables, first);
        dec.symbols(&tables, second);
        assert_eq!(back, symbols);
        dec.finish().unwrap();
        words.len() * 2
    }

    #[test]
    fn reciprocal_quotient_is_exact_for_every_frequency_and_state_below_the_spill_bound() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for f in 1..=PROB_SCALE {
            let r = reciprocal(f);
            // The encoder divides `x < f << (32 - PROB_BITS)`: the bound minus one is
            // where the product is largest.
            let bound = ((f as u64) << (32 - PROB_BITS)) - 1;
            let bound = bound as u32;
            let mut xs = vec![1, f - 1, f, f + 1, bound, bound - 1, bound / f * f, bound / f * f - 1];
            for _ in 0..200 {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                xs.push((seed % (bound as u64 + 1)) as u32);
            }
            for x in xs {
                assert_eq!(quotient(x, r), x / f, "{x} / {f}");
            }
        }
    }

    #[test]
    fn skewed_source_codes_below_one_bit_per_symbol() {
        // 99 % zeros: entropy ~0.1 bit/symbol, far below Huffman's 1-bit floor.
        let symbols: Vec<u8> = (0..100_000u32).map(|i| if i % 100 == 7 { (i % 5 + 1) as u8 } else { 0 }).collect();
        let bytes = round_trip(&symbols, &vec![0; symbols.len()], 1);
        assert!(bytes < 100_000 / 8 / 5, "{bytes} bytes");
    }

    #[test]
    fn contexts_select_their_own_models() {
        let symbols: Vec<u8> = (0..5000u32).map(|i| (i * 7 % 251) as u8).collect();
        let contexts: Vec<u8> = (0..5000u32).map(|i| (i % 3) as u8).collect();
        round_trip(&symbols, &contexts, 3);
    }

    #[test]
    fn skipping_certain_symbols_decodes_like_decoding_them() {
        // Context 1 is certain (symbol 0 only); runs of it of every length mod LANES.
        let mut symbols = Vec::new();
        let mut contexts = Vec::new();
        for run in 0..3 * LANES {
            symbols.extend((0..5u8).map(|i| i * 37 % 11));
            contexts.extend([0; 5]);
            symbols.extend(std::iter::repeat_n(0, run));
            contexts.extend(std::iter::repeat_n(1, run));
        }
        let mut counts = [[0u32; 256]; 2];
        for (&s, &c) in symbols.iter().zip(&contexts) {
            counts[c as usize][s as usize] += 1;
        }
        let models: Vec<Model> = counts.iter().map(Model::from_counts).collect();
        let mut words = Vec::new();
        Encoder::default().encode(&symbols, &contexts, &models, &mut words);
        let mut tables = Tables::new();
        tables.fill(0, &models[0]);
        let mut dec = Decoder::new(&words).unwrap();
        let mut at = 0;
        for run in 0..3 * LANES {
            let mut five = [0u8; 5];
            dec.symbols(&tables, &mut five);
            assert_eq!(five[..], symbols[at..at + 5]);
            dec.skip_certain(run);
            at += 5 + run;
        }
        dec.finish().unwrap();
    }

    #[test]
    fn every_byte_value_round_trips() {
        let symbols: Vec<u8> = (0..=255u8).chain(0..=255).collect();
        round_trip(&symbols, &vec![0; symbols.len()], 1);
    }

    #[test]
    fn single_symbol_model_costs_nothing() {
        let bytes = round_trip(&[9; 10_000], &[0; 10_000], 1);
        assert_eq!(bytes, 4 * LANES);
    }

    #[test]
    fn normalised_frequencies_sum_to_scale_and_keep_rare_symbols() {
        let mut counts = [0u32; 256];
        counts[0] = 10_000_000;
        for c in counts.iter_mut().skip(1) {
            *c = 1;
        }
        let m = Model::from_counts(&counts);
        assert_eq!(m.freq.iter().map(|&f| f as u32).sum::<u32>(), PROB_SCALE);
        assert!(m.freq.iter().all(|&f| f >= 1));
    }
}
