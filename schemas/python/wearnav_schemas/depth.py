"""Depth pixels of a ``depth_frame``: the Python side of ``schemas/src/depth_codec.rs``.

    >>> img = decode_depth(frame)                      # a decoded depth_frame body
    >>> img = decode_depth("Lossless", data, 640, 480)  # or its parts
    >>> img.shape, img.dtype
    ((480, 640), dtype('uint16'))

Mirrors the Rust decoder step for step (see the format notes at the top of
``depth_codec.rs``): a rANS side stream (level values, per-row validity runs,
escapes), then rANS residuals under 8 contexts, undone through LOCO-I's median edge
predictor on level indices. Pure Python, so a 640x480 frame takes about a second:
fine for monitors and tests, not for 30 Hz.
"""

import numpy as np

FORMAT_TAG = 0xD1
PROB_BITS = 12
PROB_SCALE = 1 << PROB_BITS
SLOT_MASK = PROB_SCALE - 1
STATE_LOW = 1 << 16
LANES = 4
CONTEXTS = 8
ESCAPE = 255
MAX_PIXELS = 1 << 24
ACTIVITY_CLASS = (0, 1, 1, 2, 2, 2, 2, 3)


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
    if sum(freqs) == 0:
        return [0] * PROB_SCALE
    table = []
    for sym, f in enumerate(freqs):
        table.extend(sym | ((f - 1) << 8) | (off << 20) for off in range(f))
    return table


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
        nxt = (((e >> 8) & 0xFFF) + 1) * (x >> PROB_BITS) + (e >> 20)
        if nxt < STATE_LOW:
            w = self.words[self.pos] if self.pos < len(self.words) else 0
            nxt = (nxt << 16) | w
            self.pos += 1
        self.lanes = self.lanes[1:] + [nxt]
        return e & 0xFF

    def finish(self):
        if self.pos != len(self.words) or any(x != STATE_LOW for x in self.lanes):
            raise DepthCodecError(f"{self.what} does not decode")


def _med(a, b, c):
    lo, hi = (a, b) if a < b else (b, a)
    if c >= hi:
        return lo
    if c <= lo:
        return hi
    return a + b - c


def _unpack(data, width, height):
    n = width * height
    if n == 0:
        if bytes(data) != bytes([FORMAT_TAG]):
            raise DepthCodecError("empty image with a body")
        return np.zeros((height, width), dtype=np.uint16)
    cur = _Cursor(data)
    if cur.byte() != FORMAT_TAG:
        raise DepthCodecError("bad format tag")
    side_len = cur.varint("side length")
    if side_len > 8 * n + (1 << 20):
        raise DepthCodecError("side stream longer than any image needs")
    side_table = _read_table(cur, "side model")
    dec = _Rans(cur.words("side words"), "side stream")
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
    runs = []
    for _ in range(height):
        row_runs = []
        x = 0
        while True:
            valid = sc.varint("validity runs")
            x += valid
            row_runs.append(valid)
            if x > width:
                raise DepthCodecError("validity runs overflow the row")
            if x == width:
                break
            invalid = sc.varint("validity runs")
            x += invalid
            row_runs.append(invalid)
            if x > width:
                raise DepthCodecError("validity runs overflow the row")
            if x == width:
                break
        runs.append(row_runs)

    tables = [_read_table(cur, "residual model") for _ in range(CONTEXTS)]
    words = cur.words("residual words")
    if cur.pos != len(data):
        raise DepthCodecError("trailing bytes")
    dec = _Rans(words, "residual stream")

    out = np.zeros((height, width), dtype=np.uint16)
    prev = [0] * (width + 2)
    calm = [True] * width
    for y in range(height):
        row = [0] * (width + 2)
        row[0] = prev[1]
        out_row = [0] * width
        x = 0
        it = iter(runs[y])
        while True:
            valid = next(it)
            for xi in range(x, x + valid):
                a, b, c, d = row[xi], prev[xi + 1], prev[xi], prev[xi + 2]
                activity = min(abs(b - c) + abs(d - b), 7)
                ctx = ACTIVITY_CLASS[activity] * 2 + (1 if calm[xi] else 0)
                z = dec.symbol(tables[ctx])
                if z == ESCAPE:
                    z = ESCAPE + sc.varint("escapes")
                calm[xi] = z == 0
                r = (z >> 1) ^ -(z & 1)
                level = _med(a, b, c) + r
                if not 1 <= level <= n_levels:
                    raise DepthCodecError("level index out of range")
                row[xi + 1] = level
                out_row[xi] = levels[level]
            x += valid
            if x == width:
                break
            invalid = next(it)
            for xi in range(x, x + invalid):
                row[xi + 1] = _med(row[xi], prev[xi + 1], prev[xi])
                calm[xi] = True
            x += invalid
            if x == width:
                break
        row[width + 1] = row[width]
        out[y] = out_row
        prev = row
    dec.finish()
    if sc.pos != len(side):
        raise DepthCodecError("unused escapes")
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
