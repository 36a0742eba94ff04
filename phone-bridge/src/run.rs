//! The bridge's loop: an axum server plus the Zenoh subscriptions behind `/health`.

use std::collections::BTreeSet;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Context;
use axum::{extract::State, response::Html, routing::get, Json, Router};
use bus::{BusOptions, Health, Shutdown, Subscriber};
use schemas::Hazard;
use serde::Serialize;
use zenoh::sample::SampleKind;

/// Agent name: liveliness token `health/phone-bridge`.
pub const AGENT: &str = "phone-bridge";

/// Everything the bridge needs to run.
#[derive(Debug, Clone)]
pub struct PhoneConfig {
    /// Bus and user.
    pub bus: BusOptions,
    /// HTTP address the phone opens (`0.0.0.0:8080` to reach it from the LAN).
    pub http: SocketAddr,
    /// Period of health stats.
    pub health_period: Duration,
}

impl PhoneConfig {
    /// Defaults for `bus`: serve on every interface, port 8080.
    pub fn new(bus: BusOptions) -> Self {
        Self { bus, http: SocketAddr::from(([0, 0, 0, 0], 8080)), health_period: Duration::from_secs(1) }
    }
}

/// What `/health` reports.
#[derive(Debug, Clone, Default, Serialize)]
pub struct BridgeView {
    /// User served.
    pub user: String,
    /// Agents whose liveliness token is present.
    pub agents_alive: BTreeSet<String>,
    /// Rumble state of the last hazard, if any arrived.
    pub last_rumble: Option<String>,
    /// Ground state of the last hazard.
    pub last_ground: Option<String>,
    /// Age of the last hazard at receipt, ms.
    pub last_hazard_age_ms: Option<f64>,
    /// Hazards received.
    pub hazards: u64,
}

type Shared = Arc<Mutex<BridgeView>>;

const PAGE: &str = include_str!("../static/index.html");

async fn page() -> Html<&'static str> {
    Html(PAGE)
}

async fn health_view(State(view): State<Shared>) -> Json<BridgeView> {
    Json(view.lock().unwrap_or_else(|e| e.into_inner()).clone())
}

/// Run the bridge until `shutdown`. Reports the bound address through `bound` (the
/// demo and tests ask for port 0 and need to know which port they got).
pub async fn run(
    config: PhoneConfig,
    shutdown: Shutdown,
    bound: Option<tokio::sync::oneshot::Sender<SocketAddr>>,
) -> anyhow::Result<()> {
    let keys = config.bus.keys()?;
    let session = bus::open_session(&config.bus).await?;
    let health = Health::new(AGENT);
    let mut health_task = health.spawn(session.clone(), keys.clone(), config.health_period, shutdown.clone());
    let view: Shared = Arc::new(Mutex::new(BridgeView { user: config.bus.user.clone(), ..Default::default() }));

    let hazards = Subscriber::<Hazard>::declare(&session, keys.hazard(), true, &health).await?;
    let liveliness = session
        .liveliness()
        .declare_subscriber(keys.health_any())
        .history(true)
        .await
        .map_err(|e| anyhow::anyhow!("cannot watch liveliness: {e}"))?;

    let listener = tokio::net::TcpListener::bind(config.http).await.with_context(|| {
        format!("cannot serve the phone page on {} (port taken? try --http 0.0.0.0:8081)", config.http)
    })?;
    let addr = listener.local_addr()?;
    tracing::info!("phone bridge serving http://{addr}/ for user {}", config.bus.user);
    if let Some(tx) = bound {
        let _ = tx.send(addr);
    }
    let app = Router::new().route("/", get(page)).route("/health", get(health_view)).with_state(view.clone());
    let server_shutdown = shutdown.clone();
    let server = tokio::spawn(async move {
        axum::serve(listener, app).with_graceful_shutdown(async move { server_shutdown.triggered().await }).await
    });
    health.set_status(true, format!("serving http://{addr}/"));

    loop {
        tokio::select! {
            _ = shutdown.triggered() => break,
            e = health_task.failed() => {
                server.abort();
                return Err(e);
            }
            Some(h) = hazards.recv() => {
                let mut v = view.lock().unwrap_or_else(|e| e.into_inner());
                v.hazards += 1;
                v.last_rumble = Some(format!("{:?}", h.body.rumble).to_lowercase());
                v.last_ground = Some(format!("{:?}", h.body.ground).to_lowercase());
                v.last_hazard_age_ms = Some(h.age_ms());
            }
            Ok(sample) = liveliness.recv_async() => {
                let Some(agent) = keys.agent_of(sample.key_expr().as_str()) else { continue };
                let mut v = view.lock().unwrap_or_else(|e| e.into_inner());
                match sample.kind() {
                    SampleKind::Put => v.agents_alive.insert(agent.to_string()),
                    SampleKind::Delete => v.agents_alive.remove(agent),
                };
            }
        }
    }
    match server.await {
        Ok(Ok(())) => {}
        Ok(Err(e)) => tracing::warn!("phone page server: {e}"),
        Err(e) => tracing::warn!("phone page server task: {e}"),
    }
    health_task.join().await?;
    session.close().await.map_err(|e| anyhow::anyhow!("{e}")).context("closing the Zenoh session")?;
    Ok(())
}
