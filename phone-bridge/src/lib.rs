//! wearnav phone bridge: serves the phone web app (an accessible page to pick a
//! destination, hear guidance and feel cues) and carries it to and from one user's
//! Zenoh keys over a WebSocket. HTTPS with a certificate it makes and keeps (phone
//! browsers allow sensors, speech input and vibration only in a secure context);
//! pairing by a spoken code so nobody else on the Wi-Fi can use or watch the socket.
//! The same socket feeds the monitor page (`/monitor`) for a sighted helper: scan,
//! rumble, utterances, map and pose, route, agents' health. docs/phone.md has the protocol.

pub mod clock;
pub mod monitor;
pub mod pairing;
pub mod protocol;
pub mod run;
pub mod tls;

pub use run::{run, PhoneConfig, Serve, AGENT};
