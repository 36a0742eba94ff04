"""Bincode's legacy (bincode-1) layout, as the Rust side writes it with bincode 2
``config::legacy()`` (see ``schemas/src/wire.rs``).

Each wire type is a small object that can ``read`` itself from a :class:`Reader` and
``write`` itself into a ``bytearray``; messages are built from them in
``messages.py``, one table entry per Rust struct, so decode and encode share one spec.

Layout rules: fixed-width little-endian integers and floats, ``bool`` as one byte
0/1, ``String`` and ``Vec<T>`` with a ``u64`` length prefix, fixed arrays ``[T; N]``
as N plain values, ``Option`` as a ``u8`` tag 0/1 then the value, enums as a ``u32``
variant index then the variant's fields.

Python values mirror serde's JSON view of the Rust value: structs are dicts with the
Rust field names, unit enum variants are their name (``"Raw"``), struct variants are
``{"Bounded": {"step": 4}}``, ``None`` is ``Option::None``, ``Vec<u8>`` is ``bytes``.

Errors are :class:`WireError` with the ``kind`` of Rust's ``WireError::kind()``.
"""

import math
import numbers
import operator
import struct

#: Hard ceiling for any payload, and bincode's decode limit (wire.rs ``MAX_PAYLOAD_BYTES``).
MAX_PAYLOAD_BYTES = 8 * 1024 * 1024


class WireError(Exception):
    """A payload was rejected. ``kind`` is Rust's ``WireError::kind()`` string:
    ``unknown_schema``, ``unknown_version``, ``wrong_schema``, ``too_large``,
    ``truncated``, ``corrupt`` or ``malformed``."""

    def __init__(self, kind, message):
        super().__init__(message)
        self.kind = kind


class Reader:
    """A cursor over one bincode decode call (header and body are separate calls in
    Rust, each with its own byte count against the limit)."""

    def __init__(self, data, pos=0):
        self.data = data
        self.pos = pos
        self.start = pos

    def take(self, size):
        """The next ``size`` bytes, or ``truncated``."""
        end = self.pos + size
        if end > len(self.data):
            raise WireError("truncated", "payload truncated")
        chunk = self.data[self.pos:end]
        self.pos = end
        return chunk

    def unpack(self, fmt, size):
        """One ``struct`` value of ``size`` bytes."""
        if self.pos + size > len(self.data):
            raise WireError("truncated", "payload truncated")
        (value,) = struct.unpack_from(fmt, self.data, self.pos)
        self.pos += size
        return value

    def claim(self, size):
        """Mirror bincode's allocation limit: a string claims its length before it is
        read, so a forged length past the limit is ``too_large`` even when the payload
        is short (Rust maps ``LimitExceeded`` to ``TooLarge``)."""
        if (self.pos - self.start) + size > MAX_PAYLOAD_BYTES:
            raise WireError(
                "too_large",
                f"payload of {len(self.data)} bytes exceeds the {MAX_PAYLOAD_BYTES}-byte limit",
            )


def _fail(path, what):
    raise ValueError(f"{path}: {what}")


class Int:
    """A fixed-width little-endian integer (``u8``..``u64``, ``i32``..)."""

    def __init__(self, name, fmt):
        self.name = name
        self.fmt = "<" + fmt
        self.size = struct.calcsize(self.fmt)

    def read(self, r):
        return r.unpack(self.fmt, self.size)

    def write(self, out, value, path):
        try:
            if isinstance(value, bool):
                raise TypeError
            value = operator.index(value)  # ints, and numpy integers too
        except TypeError:
            _fail(path, f"expected an integer ({self.name}), got {value!r}")
        try:
            out += struct.pack(self.fmt, value)
        except struct.error:
            _fail(path, f"{value} does not fit in {self.name}")

    def to_json(self, value, summarise_bytes):
        return value


class Float:
    """An IEEE float; ``f32`` values are rounded to single precision on write."""

    def __init__(self, name, fmt):
        self.name = name
        self.fmt = "<" + fmt
        self.size = struct.calcsize(self.fmt)

    def read(self, r):
        return r.unpack(self.fmt, self.size)

    def write(self, out, value, path):
        if not isinstance(value, numbers.Real) or isinstance(value, bool):
            _fail(path, f"expected a number ({self.name}), got {value!r}")
        try:
            out += struct.pack(self.fmt, value)
        except (OverflowError, struct.error):
            _fail(path, f"{value} does not fit in {self.name}")

    def to_json(self, value, summarise_bytes):
        """serde_json's view: non-finite floats are ``null``; finite ones the shortest
        decimal that reads back as the same value (ryu, as serde_json prints it)."""
        if not math.isfinite(value):
            return None
        for digits in range(1, 18):
            text = f"{value:.{digits}g}"
            if struct.pack(self.fmt, float(text)) == struct.pack(self.fmt, value):
                return float(text)
        return value


class Bool:
    """``bool`` as one byte, 0 or 1; anything else is malformed."""

    def read(self, r):
        byte = r.unpack("<B", 1)
        if byte > 1:
            raise WireError("malformed", f"malformed payload: invalid bool value {byte}")
        return byte == 1

    def write(self, out, value, path):
        if not isinstance(value, bool):
            _fail(path, f"expected a bool, got {value!r}")
        out.append(1 if value else 0)

    def to_json(self, value, summarise_bytes):
        return value


def _read_len(r):
    return r.unpack("<Q", 8)


def _is_sequence(value):
    """Lists, tuples and array-likes (numpy arrays), but not text, bytes or dicts."""
    return hasattr(value, "__len__") and not isinstance(value, (str, bytes, bytearray, dict))


class Text:
    """``String``: u64 byte length, then UTF-8."""

    def read(self, r):
        size = _read_len(r)
        r.claim(size)
        raw = r.take(size)
        try:
            return bytes(raw).decode("utf-8")
        except UnicodeDecodeError as err:
            raise WireError("malformed", f"malformed payload: invalid UTF-8 ({err.reason})") from None

    def write(self, out, value, path):
        if not isinstance(value, str):
            _fail(path, f"expected a str, got {value!r}")
        raw = value.encode("utf-8")
        out += struct.pack("<Q", len(raw))
        out += raw

    def to_json(self, value, summarise_bytes):
        return value


class Bytes:
    """``Vec<u8>``: u64 length, then the bytes. serde reads it element by element, so
    a forged length is ``truncated``, not ``too_large``."""

    def read(self, r):
        return bytes(r.take(_read_len(r)))

    def write(self, out, value, path):
        if not isinstance(value, (bytes, bytearray, memoryview)):
            _fail(path, f"expected bytes, got {type(value).__name__}")
        out += struct.pack("<Q", len(value))
        out += value

    def to_json(self, value, summarise_bytes):
        return {"bytes": len(value)} if summarise_bytes else list(value)


class Seq:
    """``Vec<T>``: u64 element count, then the elements."""

    def __init__(self, item):
        self.item = item

    def read(self, r):
        count = _read_len(r)
        if isinstance(self.item, (Int, Float)):
            # One unpack for the whole run (a scan has 360 floats); same bytes, same errors.
            size = count * self.item.size
            if r.pos + size > len(r.data):
                raise WireError("truncated", "payload truncated")
            values = struct.unpack_from(f"<{count}{self.item.fmt[1:]}", r.data, r.pos)
            r.pos += size
            return list(values)
        return [self.item.read(r) for _ in range(count)]

    def write(self, out, value, path):
        if not _is_sequence(value):
            _fail(path, f"expected a list, got {value!r}")
        out += struct.pack("<Q", len(value))
        for i, item in enumerate(value):
            self.item.write(out, item, f"{path}[{i}]")

    def to_json(self, value, summarise_bytes):
        return [self.item.to_json(v, summarise_bytes) for v in value]


class Array:
    """``[T; N]``: N values, no length prefix."""

    def __init__(self, item, count):
        self.item = item
        self.count = count

    def read(self, r):
        return [self.item.read(r) for _ in range(self.count)]

    def write(self, out, value, path):
        if not _is_sequence(value) or len(value) != self.count:
            _fail(path, f"expected a list of {self.count} values, got {value!r}")
        for i, item in enumerate(value):
            self.item.write(out, item, f"{path}[{i}]")

    def to_json(self, value, summarise_bytes):
        return [self.item.to_json(v, summarise_bytes) for v in value]


class Optional:
    """``Option<T>``: tag 0 (``None``) or 1 then the value; other tags are malformed."""

    def __init__(self, item):
        self.item = item

    def read(self, r):
        tag = r.unpack("<B", 1)
        if tag == 0:
            return None
        if tag == 1:
            return self.item.read(r)
        raise WireError("malformed", f"malformed payload: Option tag {tag} (expected 0 or 1)")

    def write(self, out, value, path):
        if value is None:
            out.append(0)
        else:
            out.append(1)
            self.item.write(out, value, path)

    def to_json(self, value, summarise_bytes):
        return None if value is None else self.item.to_json(value, summarise_bytes)


class Struct:
    """A Rust struct: its fields in declaration order, nothing in between.
    ``Struct("MountGuess", height_m=F32, pitch_deg=F32)``."""

    def __init__(self, name, **fields):
        self.name = name
        self.fields = fields

    def read(self, r):
        return {field: kind.read(r) for field, kind in self.fields.items()}

    def write(self, out, value, path):
        if not isinstance(value, dict):
            _fail(path, f"expected a dict of {self.name} fields, got {value!r}")
        unknown = set(value) - set(self.fields)
        if unknown:
            _fail(path, f"{self.name} has no field {sorted(unknown)[0]!r}")
        for field, kind in self.fields.items():
            if field not in value:
                _fail(path, f"{self.name} field {field!r} is missing")
            kind.write(out, value[field], f"{path}.{field}")

    def to_json(self, value, summarise_bytes):
        return {f: kind.to_json(value[f], summarise_bytes) for f, kind in self.fields.items()}


class Enum:
    """A Rust enum: u32 variant index, then the variant's fields. Variants in
    declaration order, unit ones mapped to ``None``, struct ones to their fields:
    ``Enum("DepthEncoding", {"Raw": None, "Lossless": None, "Bounded": {"step": U16}})``
    (a dict, not keywords, because Rust variant names such as ``None`` are Python keywords)."""

    def __init__(self, name, variants):
        self.name = name
        self.names = list(variants)
        self.variants = {
            v: None if fields is None else Struct(f"{name}::{v}", **fields)
            for v, fields in variants.items()
        }

    def read(self, r):
        index = r.unpack("<I", 4)
        if index >= len(self.names):
            raise WireError(
                "malformed",
                f"malformed payload: variant index {index} of {self.name} "
                f"(expected 0..{len(self.names) - 1})",
            )
        variant = self.names[index]
        fields = self.variants[variant]
        return variant if fields is None else {variant: fields.read(r)}

    def _split(self, value, path):
        if isinstance(value, str):
            variant, fields = value, None
        elif isinstance(value, dict) and len(value) == 1:
            ((variant, fields),) = value.items()
        else:
            _fail(path, f"expected a {self.name} variant name or {{name: fields}}, got {value!r}")
        if variant not in self.variants:
            _fail(path, f"{self.name} has no variant {variant!r} (one of {', '.join(self.names)})")
        if (self.variants[variant] is None) != (fields is None):
            kind = "a unit" if self.variants[variant] is None else "a struct"
            _fail(path, f"{self.name}::{variant} is {kind} variant")
        return variant, fields

    def write(self, out, value, path):
        variant, fields = self._split(value, path)
        out += struct.pack("<I", self.names.index(variant))
        if fields is not None:
            self.variants[variant].write(out, fields, f"{path}.{variant}")

    def to_json(self, value, summarise_bytes):
        if isinstance(value, str):
            return value
        ((variant, fields),) = value.items()
        return {variant: self.variants[variant].to_json(fields, summarise_bytes)}


U8 = Int("u8", "B")
U16 = Int("u16", "H")
U32 = Int("u32", "I")
U64 = Int("u64", "Q")
I32 = Int("i32", "i")
I64 = Int("i64", "q")
F32 = Float("f32", "f")
F64 = Float("f64", "d")
BOOL = Bool()
STRING = Text()
BYTES = Bytes()
