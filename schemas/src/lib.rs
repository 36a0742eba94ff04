//! The wearnav wire contract: message types, key expressions, codec and versioning.
//!
//! Everything that crosses the bus is defined here and nowhere else, so the agents, the
//! Python decoder (`schemas/python`) and the golden vectors (`schemas/vectors`) agree.
//! This crate knows nothing of Zenoh: the `bus` crate carries these bytes.

pub mod depth_codec;
pub mod guard;
pub mod keys;
pub mod messages;
pub mod wire;

pub use keys::{KeyError, Keys};
pub use messages::*;
pub use wire::{decode, decode_header, encode, encode_into, Header, Message, Origin, SchemaId, WireError};
