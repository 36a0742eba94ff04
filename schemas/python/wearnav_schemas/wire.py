"""Envelope, encode and decode, mirroring ``schemas/src/wire.rs`` check for check.

A payload is the ``Header`` then the body, both in bincode's legacy layout
(``layout.py``), then the CRC-32 (``zlib.crc32``) of all that, little-endian.
Decoding bounds the payload size before reading anything, rejects unknown schema ids
and versions, refuses a payload whose checksum does not match (``corrupt``) and
trailing bytes, with the same error kinds as Rust's ``WireError``. Rust's semantic ``validate()`` checks (NaN levels, empty
utterances) are not repeated here: a monitor shows what was on the wire.
"""

import secrets
import struct
import zlib
from dataclasses import dataclass

from .layout import MAX_PAYLOAD_BYTES, Reader, WireError
from .messages import HEADER, SCHEMAS

#: Bytes of the checksum trailer.
CHECKSUM_BYTES = 4
#: This process's publisher session (``Header.session``): receivers tell a restarted
#: sender, numbering from 0 again, from a replay by it.
PROCESS_SESSION = secrets.randbits(64)

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
    ``application/octet-stream;wearnav/hazard/v5``, or ``None`` when it names none."""
    _, _, tail = str(encoding).partition(";")
    parts = tail.split("/")
    if len(parts) == 3 and parts[0] == "wearnav" and parts[1] in BY_NAME:
        return parts[1]
    return None


def _too_large(size, limit):
    return WireError("too_large", f"payload of {size} bytes exceeds the {limit}-byte limit")


def reseal(payload):
    """``payload`` (bytes) with its checksum trailer rewritten to match the bytes before
    it: for tests that damage a payload's inside on purpose."""
    body = bytes(payload[:-CHECKSUM_BYTES])
    return body + struct.pack("<I", zlib.crc32(body))


def _schema_version(payload):
    """The schema of the first four bytes, checked before the checksum so a payload of
    another build's layout is named as such, not as damaged."""
    if len(payload) < 4:
        raise WireError("truncated", "payload truncated")
    schema_id, version = struct.unpack_from("<HH", payload)
    found = BY_ID.get(schema_id)
    if found is None:
        raise WireError("unknown_schema", f"unknown schema id {schema_id}")
    if version != found.version:
        raise WireError(
            "unknown_version",
            f"{found.name} version {version} not supported (this build speaks v{found.version})",
        )
    return found


def _verified(payload):
    """The payload without its trailer, once the trailer matches."""
    if len(payload) < CHECKSUM_BYTES:
        raise WireError("truncated", "payload truncated")
    body = memoryview(payload)[: len(payload) - CHECKSUM_BYTES]
    (found,) = struct.unpack_from("<I", payload, len(payload) - CHECKSUM_BYTES)
    computed = zlib.crc32(body)
    if found != computed:
        raise WireError(
            "corrupt",
            f"checksum mismatch: payload damaged or cut short (crc {found:08x}, computed {computed:08x})",
        )
    return body


def decode_header(payload):
    """Read only the envelope: ``(header, bytes used)``. Rejects oversized payloads,
    unknown schema ids, versions other than the schema's own, and a checksum that does
    not match."""
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise _too_large(len(payload), MAX_PAYLOAD_BYTES)
    _schema_version(payload)
    reader = Reader(_verified(payload))
    header = HEADER.read(reader)
    return header, reader.pos


def decode(payload, expected=None):
    """Decode a payload into a :class:`Message`, dispatching on its header. With
    ``expected`` (a schema name) it behaves like Rust's ``decode::<M>``: the size bound
    of that schema first, then ``wrong_schema`` for any other. Raises :class:`WireError`."""
    limit = schema(expected).max_bytes if expected else MAX_PAYLOAD_BYTES
    if len(payload) > limit:
        raise _too_large(len(payload), limit)
    found = _schema_version(payload)
    if expected and found.name != expected:
        raise WireError("wrong_schema", f"expected a {expected} payload, got {found.id}")
    if len(payload) > found.max_bytes:
        raise _too_large(len(payload), found.max_bytes)
    header, used = decode_header(payload)
    body_bytes = memoryview(payload)[: len(payload) - CHECKSUM_BYTES]
    reader = Reader(body_bytes, used)
    body = found.body.read(reader)
    if reader.pos != len(body_bytes):
        raise WireError(
            "malformed",
            f"malformed payload: {len(body_bytes) - reader.pos} trailing bytes "
            f"after the {found.name} body",
        )
    return Message(found.name, header, body)


def encode(name, body, *, sender, seq, capture_ns, session=None):
    """Encode ``body`` (a dict shaped like the Rust struct) as a ``name`` payload behind
    an envelope, checksum last; schema id and version are filled in, ``session`` is
    this process's (:data:`PROCESS_SESSION`) unless given. ``ValueError`` names the
    field that does not fit."""
    found = schema(name)
    out = bytearray()
    header = {
        "schema": found.id,
        "version": found.version,
        "sender": sender,
        "session": PROCESS_SESSION if session is None else session,
        "seq": seq,
        "capture_ns": capture_ns,
    }
    HEADER.write(out, header, "header")
    found.body.write(out, body, name)
    out += struct.pack("<I", zlib.crc32(out))
    return bytes(out)
