//! The wearnav bus: Zenoh sessions, typed publishers and subscribers that encode,
//! decode and count rejects, per-stream QoS, liveliness and periodic health stats.
//!
//! This is the imperative shell shared by every agent: only code here and in each
//! agent's `run` module touches Zenoh, Tokio or the clock.

pub mod clock;
pub mod health;
pub mod logging;
pub mod query;
pub mod session;
pub mod shutdown;
pub mod stream;

pub use clock::now_ns;
pub use health::{Health, HealthTask, StreamCounter};
pub use query::{Query, Queryable};
pub use schemas::guard::{self, Freshness, InputError};
pub use session::{open_session, BusOptions};
pub use shutdown::Shutdown;
pub use stream::{Lane, Publisher, Received, Subscriber};

/// `future` when there is one, else a future that never ends: a branch of a
/// `tokio::select!` loop that exists only with some option on (navigation, pacing,
/// the demo's guided user).
pub async fn maybe<T>(future: Option<impl std::future::Future<Output = T>>) -> T {
    match future {
        Some(f) => f.await,
        None => std::future::pending().await,
    }
}
