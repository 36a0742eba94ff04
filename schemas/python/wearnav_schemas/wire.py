"""Envelope, encode and decode, mirroring ``schemas/src/wire.rs`` check for check.

A payload is the ``Header`` then the body, both in bincode's legacy layout
(``layout.py``). Decoding bounds the payload size before reading anything, rejects
unknown schema ids and versions, and refuses trailing bytes, with the same error
kinds as Rust's ``WireError``. Rust's semantic ``validate()`` checks (NaN levels, empty
utterances) are not repeated here: a monitor shows what was on the wire.
"""

from dataclasses import dataclass

from .layout import MAX_PAYLOAD_BYTES, Reader, WireError
from .messages import HEADER, SCHEMAS

#: Schema id -> schema.
BY_ID = {s.id: s for s in SCHEMAS}
#: Schema name -> schema.
BY_NAME = {s.name: s for s in SCHEMAS}
#: Schema id -> snake-case name, as in the Zenoh encoding.
SCHEMA_NAMES = {s.id: s.name for s in SCHEMAS}


@dataclass
class Message:
    """A decoded payload: the schema name, the envelope and the body (a dict, or a
    variant name for unit variants such as ``Command::WhereAmI``)."""

    schema: str
    header: dict
    body: object

    def to_json(self, summarise_bytes=False):
        """serde_json's view of header and body (non-finite floats as ``null``);
        with ``summarise_bytes`` a ``Vec<u8>`` becomes ``{"bytes": <length>}``."""
        return {
            "schema": self.schema,
            "header": HEADER.to_json(self.header, summarise_bytes),
            "body": BY_NAME[self.schema].body.to_json(self.body, summarise_bytes),
        }


def schema(name):
    """The schema called ``name``; ``ValueError`` listing the known names otherwise."""
    try:
        return BY_NAME[name]
    except KeyError:
        raise ValueError(f"unknown schema {name!r} (one of {', '.join(BY_NAME)})") from None


def encoding_schema(name):
    """Schema string carried in the Zenoh ``Encoding``: ``wearnav/<name>/v<version>``."""
    found = schema(name)
    return f"wearnav/{found.name}/v{found.version}"


def schema_of_encoding(encoding):
    """The schema name in a Zenoh encoding string such as
    ``application/octet-stream;wearnav/hazard/v2``, or ``None`` when it names none."""
    _, _, tail = str(encoding).partition(";")
    parts = tail.split("/")
    if len(parts) == 3 and parts[0] == "wearnav" and parts[1] in BY_NAME:
        return parts[1]
    return None


def _too_large(size, limit):
    return WireError("too_large", f"payload of {size} bytes exceeds the {limit}-byte limit")


def decode_header(payload):
    """Read only the envelope: ``(header, bytes used)``. Rejects oversized payloads,
    unknown schema ids and versions other than the schema's own."""
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise _too_large(len(payload), MAX_PAYLOAD_BYTES)
    reader = Reader(memoryview(payload))
    header = HEADER.read(reader)
    found = BY_ID.get(header["schema"])
    if found is None:
        raise WireError("unknown_schema", f"unknown schema id {header['schema']}")
    if header["version"] != found.version:
        raise WireError(
            "unknown_version",
            f"{found.name} version {header['version']} not supported "
            f"(this build speaks v{found.version})",
        )
    return header, reader.pos


def decode(payload, expected=None):
    """Decode a payload into a :class:`Message`, dispatching on its header. With
    ``expected`` (a schema name) it behaves like Rust's ``decode::<M>``: the size bound
    of that schema first, then ``wrong_schema`` for any other. Raises :class:`WireError`."""
    limit = schema(expected).max_bytes if expected else MAX_PAYLOAD_BYTES
    if len(payload) > limit:
        raise _too_large(len(payload), limit)
    header, used = decode_header(payload)
    found = BY_ID[header["schema"]]
    if expected and found.name != expected:
        raise WireError("wrong_schema", f"expected a {expected} payload, got {header['schema']}")
    if len(payload) > found.max_bytes:
        raise _too_large(len(payload), found.max_bytes)
    reader = Reader(memoryview(payload), used)
    body = found.body.read(reader)
    if reader.pos != len(payload):
        raise WireError(
            "malformed",
            f"malformed payload: {len(payload) - reader.pos} trailing bytes "
            f"after the {found.name} body",
        )
    return Message(found.name, header, body)


def encode(name, body, *, sender, seq, capture_ns):
    """Encode ``body`` (a dict shaped like the Rust struct) as a ``name`` payload behind
    an envelope; schema id and version are filled in. ``ValueError`` names the field
    that does not fit."""
    found = schema(name)
    out = bytearray()
    header = {
        "schema": found.id,
        "version": found.version,
        "sender": sender,
        "seq": seq,
        "capture_ns": capture_ns,
    }
    HEADER.write(out, header, "header")
    found.body.write(out, body, name)
    return bytes(out)
