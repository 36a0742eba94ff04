"""Pure-Python (stdlib ``struct``) codec of the wearnav wire contract.

Decodes and encodes every message of ``schemas/src/messages.rs`` behind the envelope
of ``schemas/src/wire.rs``, byte for byte as Rust's bincode 2 ``config::legacy()``
writes them; the golden vectors in ``schemas/vectors`` keep both sides equal.

    >>> from wearnav_schemas import Keys, decode, encode
    >>> payload = encode("command", {"Destination": {"label": "kitchen"}},
    ...                  sender="me", seq=0, capture_ns=0)
    >>> decode(payload).body
    {'Destination': {'label': 'kitchen'}}
    >>> Keys("alice").hazard()
    'wearnav/alice/perception/hazard'
"""

from .keys import COMMAND_VERBS, KeyNameError, Keys, check_chunk, command_verb
from .layout import MAX_PAYLOAD_BYTES, WireError
from .messages import SCHEMAS, Schema
from .summary import summarise
from .wire import (
    SCHEMA_NAMES,
    Message,
    decode,
    decode_header,
    encode,
    encoding_schema,
    schema,
    schema_of_encoding,
)


def depth_samples(frame):
    """The depth samples of a decoded ``depth_frame`` body: a ``(height, width)`` uint16
    array, 0 = invalid.
    Imports the pixel codec (``depth.py``, numpy) only here, so the package itself needs
    nothing beyond the standard library."""
    from .depth import decode_depth

    return decode_depth(frame)


__all__ = [
    "COMMAND_VERBS",
    "KeyNameError",
    "Keys",
    "MAX_PAYLOAD_BYTES",
    "Message",
    "SCHEMAS",
    "SCHEMA_NAMES",
    "Schema",
    "WireError",
    "check_chunk",
    "command_verb",
    "decode",
    "decode_header",
    "depth_samples",
    "encode",
    "encoding_schema",
    "schema",
    "schema_of_encoding",
    "summarise",
]
