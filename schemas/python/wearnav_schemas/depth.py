"""Depth pixels of a ``depth_frame``: the Python side of ``schemas/src/depth_codec.rs``.

    >>> img = decode_depth(frame)                      # a decoded depth_frame body
    >>> img = decode_depth("Lossless", data, 640, 480)  # or its parts
    >>> img.shape, img.dtype
    ((480, 640), dtype('uint16'))

Mirrors the Rust decoder step for step (see the format notes at the top of
``depth_codec.rs``, format version 3): a rANS side stream (level values, per-row
validity runs, models, escapes), rANS exceptions, then rANS quad symbols (four 2-bit
residual codes) under 8 contexts from the row above (a ninth, whose only symbol is 0,
for quads with no valid pixel), undone by left prediction on level indices. Pure
Python, so a 640x480 frame takes a few tenths of a second: fine for monitors and
tests, not for 30 Hz.
"""

import numpy as np

FORMAT_TAG = 0xD3
PROB_BITS = 10
PROB_SCALE = 1 << PROB_BITS
SLOT_MASK = PROB_SCALE - 1
STATE_LOW = 1 << 16
LANES = 4
CONTEXTS = 8
UNCODED = CONTEXTS
QUAD = 4
EXCEPTION = 3
ESCAPE = 255
FIRST_EXCEPTION = 3
MAX_PIXELS = 1 << 24
CODE_RESIDUAL = (0, 1, -1, 0)


def _activity(sym):
    """Activity class of a quad symbol: its codes' sizes (0, 1 for +-1, 2 for an
    exception) summed and capped at 3."""
    total = sum((0, 1, 1, 2)[(sym >> (2 * i)) & 3] for i in range(QUAD))
    return min(total, 3)


ACTIVITY = tuple(_activity(s) for s in range(256))


class DepthCodecError(ValueError):
    """A depth payload that does not decode (truncated, corrupt, wrong size)."""


class _Cursor:
    def __init__(self, data):
        self.data = data
        self.pos = 0

    def byte(self):
        if self.pos >= len(self.data):
            raise DepthCodecError("truncated payload")
        b = self.data[self.pos]
        self.pos += 1
        return b

    def varint(self, what):
        value = 0
        for shift in (0, 7, 14, 21, 28):
            if self.pos >= len(self.data):
                raise DepthCodecError(f"truncated {what}")
            b = self.data[self.pos]
            self.pos += 1
            value |= (b & 0x7F) << shift
            if b < 0x80:
                if shift == 28 and b > 0x0F:
                    break
                return value
        raise DepthCodecError(f"bad varint in {what}")

    def words(self, what):
        count = self.varint(what)
        end = self.pos + 2 * count
        if end > len(self.data):
            raise DepthCodecError(f"truncated {what}")
        words = np.frombuffer(self.data[self.pos:end], dtype="<u2").tolist()
        self.pos = end
        return words


def _read_table(cur, what):
    """A model's decoding table: per slot ``(symbol, freq, offset)`` packed in an int."""
    used = cur.varint(what)
    if used > 256:
        raise DepthCodecError(f"bad {what}")
    freqs = [cur.varint(what) for _ in range(used)]
    if any(f > PROB_SCALE for f in freqs) or sum(freqs) not in (0, PROB_SCALE):
        raise DepthCodecError(f"bad {what}")
    return _table(freqs)


def _table(freqs):
    if sum(freqs) == 0:
        return [0] * PROB_SCALE
    table = []
    for sym, f in enumerate(freqs):
        table.extend(sym | ((f - 1) << 8) | (off << (8 + PROB_BITS)) for off in range(f))
    return table


# The uncoded quads' model: symbol 0 in every slot, so it costs no bits.
UNCODED_TABLE = _table([PROB_SCALE])


class _Rans:
    def __init__(self, words, what):
        if len(words) < 2 * LANES:
            raise DepthCodecError(f"{what} too short")
        self.words = words
        self.pos = 2 * LANES
        self.lanes = [words[2 * i] << 16 | words[2 * i + 1] for i in range(LANES)]
        self.what = what

    def symbol(self, table):
        x = self.lanes[0]
        e = table[x & SLOT_MASK]
        nxt = (((e >> 8) & SLOT_MASK) + 1) * (x >> PROB_BITS) + (e >> (8 + PROB_BITS))
        if nxt < STATE_LOW:
            w = self.words[self.pos] if self.pos < len(self.words) else 0
            nxt = (nxt << 16) | w
            self.pos += 1
        self.lanes = self.lanes[1:] + [nxt]
        return e & 0xFF

    def finish(self):
        if self.pos != len(self.words) or any(x != STATE_LOW for x in self.lanes):
            raise DepthCodecError(f"{self.what} does not decode")


def _read_runs(sc, width, height):
    """Per row, the validity of each pixel, from alternating valid/invalid runs."""
    rows = []
    for _ in range(height):
        valid = []
        x = 0
        while True:
            run = sc.varint("validity runs")
            x += run
            if x > width:
                raise DepthCodecError("validity runs overflow the row")
            valid.extend([True] * run)
            if x == width:
                break
            run = sc.varint("validity runs")
            x += run
            if x > width:
                raise DepthCodecError("validity runs overflow the row")
            valid.extend([False] * run)
            if x == width:
                break
        rows.append(valid)
    return rows


def _unpack(data, width, height):
    n = width * height
    if n == 0:
        if bytes(data) != bytes([FORMAT_TAG]):
            raise DepthCodecError("empty image with a body")
        return np.zeros((height, width), dtype=np.uint16)
    cur = _Cursor(data)
    if cur.byte() != FORMAT_TAG:
        raise DepthCodecError("unknown format tag (not a version 3 payload)")
    side_len = cur.varint("side length")
    if side_len > 8 * n + (1 << 20):
        raise DepthCodecError("side stream longer than any image needs")
    side_table = _read_table(cur, "side model")
    side_words = cur.words("side words")
    quad_words = cur.words("quad words")
    exception_words = cur.words("exception words")
    if cur.pos != len(data):
        raise DepthCodecError("trailing bytes")
    dec = _Rans(side_words, "side stream")
    side = bytes(dec.symbol(side_table) for _ in range(side_len))
    dec.finish()

    sc = _Cursor(side)
    n_levels = sc.varint("level count")
    if n_levels > 65535:
        raise DepthCodecError("more levels than u16 values")
    levels = [0]
    value = 0
    for _ in range(n_levels):
        gap = sc.varint("levels")
        value += gap
        if gap == 0 or value > 65535:
            raise DepthCodecError("levels not strictly increasing in 1..=65535")
        levels.append(value)
    validity = _read_runs(sc, width, height)
    quad_tables = [_read_table(sc, "quad model") for _ in range(CONTEXTS)] + [UNCODED_TABLE]
    exception_table = _read_table(sc, "exception model")
    n_exceptions = sc.varint("exception count")
    if n_exceptions > n:
        raise DepthCodecError("more exceptions than pixels")
    dec = _Rans(exception_words, "exception stream")
    exception_bytes = [dec.symbol(exception_table) for _ in range(n_exceptions)]
    dec.finish()
    residuals = []
    for e in exception_bytes:
        if e == ESCAPE:
            e = ESCAPE + sc.varint("escapes")
        z = e + FIRST_EXCEPTION
        residuals.append((z >> 1) ^ -(z & 1))
    if sc.pos != len(side):
        raise DepthCodecError("unused side bytes")

    n_quads = (width + QUAD - 1) // QUAD
    dec = _Rans(quad_words, "quad stream")
    out = np.zeros((height, width), dtype=np.uint16)
    above = [0] * (n_quads + 1)
    pending = iter(residuals)
    row_start = 1
    for y in range(height):
        valid = validity[y] + [False] * (n_quads * QUAD - width)
        quads = [0] * (n_quads + 1)
        for q in range(n_quads):
            if any(valid[q * QUAD:(q + 1) * QUAD]):
                ctx = ACTIVITY[above[q]] * 2 + (1 if above[q + 1] else 0)
            else:
                ctx = UNCODED
            quads[q] = dec.symbol(quad_tables[ctx])
        left = row_start
        out_row = [0] * width
        for x in range(n_quads * QUAD):
            code = (quads[x // QUAD] >> (2 * (x % QUAD))) & 3
            if not valid[x]:
                if code:
                    raise DepthCodecError("residual code on an invalid pixel")
            else:
                if code == EXCEPTION:
                    r = next(pending, None)
                    if r is None:
                        raise DepthCodecError("missing exception")
                else:
                    r = CODE_RESIDUAL[code]
                left += r
                if not 1 <= left <= n_levels:
                    raise DepthCodecError("level index out of range")
                out_row[x] = levels[left]
            if x == 0:
                row_start = left
        out[y] = out_row
        above = quads
    dec.finish()
    if next(pending, None) is not None:
        raise DepthCodecError("unused exceptions")
    return out


def _encoding_name(encoding):
    if isinstance(encoding, str):
        return encoding, None
    if isinstance(encoding, dict) and len(encoding) == 1:
        ((name, fields),) = encoding.items()
        return name, fields
    raise DepthCodecError(f"unknown depth encoding {encoding!r}")


def decode_depth(encoding, data=None, width=None, height=None):
    """Depth samples as a ``(height, width)`` uint16 array, 0 = invalid.

    Pass a decoded ``depth_frame`` body, or its ``encoding`` (``"Raw"``,
    ``"Lossless"`` or ``{"Bounded": {"step": n}}``), ``data``, ``width``, ``height``.
    Raises ``DepthCodecError`` for payloads that do not decode."""
    if data is None:
        frame = encoding
        encoding, data, width, height = frame["encoding"], frame["data"], frame["width"], frame["height"]
    data = bytes(data)
    if width * height > MAX_PIXELS:
        raise DepthCodecError(f"{width}x{height} is larger than the {MAX_PIXELS}-pixel limit")
    name, fields = _encoding_name(encoding)
    if name == "Raw":
        if len(data) != 2 * width * height:
            raise DepthCodecError(f"{len(data) // 2} samples for a {width}x{height} image")
        return np.frombuffer(data, dtype="<u2").astype(np.uint16).reshape(height, width)
    if name == "Bounded" and (not fields or fields.get("step", 0) == 0):
        raise DepthCodecError("bounded encoding needs a step of at least 1 depth unit")
    if name not in ("Lossless", "Bounded"):
        raise DepthCodecError(f"unknown depth encoding {encoding!r}")
    return _unpack(data, width, height)
