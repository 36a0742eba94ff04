//! The bridge's loop: an axum server (the page, `/monitor`, `/health`, `/pair`, `/ws`)
//! and the Zenoh side that carries one user's keys to and from the paired phones, and
//! to the monitor pages that subscribed.

use std::collections::{BTreeSet, HashMap};
use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context};
use axum::extract::ws::{Message as WsMessage, WebSocket, WebSocketUpgrade};
use axum::extract::{DefaultBodyLimit, Query, State};
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use bus::{BusOptions, Health, Lane, Publisher, Shutdown, Subscriber};
use schemas::{
    CameraPlace, Command, Destinations, GroundTruth, HapticIntent, Hazard, HealthStats, PhoneAck, PhoneEvent,
    PhoneHaptic, PhoneMotion, PhoneSpeech, Pose, Priority, RouteState, Scan, SpeechIntent,
};
use serde::{Deserialize, Serialize};
use tokio::sync::{broadcast, mpsc};
use zenoh::sample::SampleKind;

use crate::clock::ClockOffset;
use crate::monitor::{self, MonitorState, Stream, StreamSet, ToMonitor};
use crate::pairing::{Attempt, Pairing};
use crate::protocol::{self, FromPage, ToPage, MAX_MESSAGE_BYTES};

/// Agent name: liveliness token `health/phone-bridge`.
pub const AGENT: &str = "phone-bridge";

/// Commands a page may send per second, sustained (bursts of [`COMMAND_BURST`]).
pub const COMMANDS_PER_S: f64 = 5.0;
/// Commands a page may send at once.
pub const COMMAND_BURST: f64 = 10.0;
/// The bridge sends each page its clock this often; a page that hears nothing for
/// three periods says the connection is lost.
pub const CLOCK_PERIOD: Duration = Duration::from_secs(1);
/// Monitor messages queued for the slowest monitor page before it loses some (about
/// 3 s of the scan, the camera's place, hazard, intent, truth and pose at 30 Hz).
const MONITOR_QUEUE: usize = 512;
/// Why the bridge answers a speech request `Failed` itself.
pub const NO_PAGE: &str = "no phone page is connected";

/// How the page is served.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Serve {
    /// HTTPS (what a phone needs for sensors, speech input and vibration).
    Https(SocketAddr),
    /// Plain HTTP, on a loopback address only (tests, the demo on one machine).
    Http(SocketAddr),
}

/// Everything the bridge needs to run.
#[derive(Debug, Clone)]
pub struct PhoneConfig {
    /// Bus and user.
    pub bus: BusOptions,
    /// Where and how the page is served.
    pub serve: Serve,
    /// Where the certificate it makes and the paired phones are kept.
    pub state_dir: PathBuf,
    /// The user's own certificate and key (PEM), instead of a self-signed one.
    pub tls: Option<(PathBuf, PathBuf)>,
    /// Period of health stats.
    pub health_period: Duration,
    /// Print the address, a QR code of it and the pairing code on stdout, and have
    /// the pairing code spoken.
    pub announce: bool,
    /// A fixed six-digit pairing code instead of a new random one each start.
    pub pairing_code: Option<String>,
    /// The floor maps the monitor page draws the pose and route on (the compute
    /// agent's `--map`); none: the monitor draws them on a blank grid.
    pub map: Option<Arc<map::Building>>,
    /// The perception configuration whose cost regions the monitor page draws (the
    /// compute agent's `--perception-config`; default the thesis's).
    pub perception: perception::PerceptionConfig,
}

/// `$XDG_STATE_HOME/wearnav/phone-bridge`, else `~/.local/state/wearnav/phone-bridge`.
pub fn default_state_dir() -> PathBuf {
    let base = std::env::var_os("XDG_STATE_HOME")
        .map(PathBuf::from)
        .filter(|p| p.is_absolute())
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/state")))
        .unwrap_or_else(std::env::temp_dir);
    base.join("wearnav/phone-bridge")
}

impl PhoneConfig {
    /// Defaults for `bus`: HTTPS on every interface, port 8443.
    pub fn new(bus: BusOptions) -> Self {
        Self {
            bus,
            serve: Serve::Https(SocketAddr::from(([0, 0, 0, 0], 8443))),
            state_dir: default_state_dir(),
            tls: None,
            health_period: Duration::from_secs(1),
            announce: true,
            pairing_code: None,
            map: None,
            perception: perception::PerceptionConfig::default(),
        }
    }

    /// Refuse what would expose the user: plain HTTP beyond this machine carries the
    /// pairing token and the user's position in clear.
    pub fn check(&self) -> anyhow::Result<()> {
        if let Serve::Http(addr) = self.serve {
            if !addr.ip().is_loopback() {
                bail!(
                    "plain HTTP on {addr} would let anyone on the network read the pairing token and the \
                     user's position: serve HTTPS (--https {addr}), or plain HTTP on a loopback address \
                     (--http 127.0.0.1:{})",
                    addr.port()
                );
            }
        }
        if let Some(code) = &self.pairing_code {
            if code.len() != 6 || !code.bytes().all(|b| b.is_ascii_digit()) {
                bail!("the pairing code must be six digits, not {code:?}");
            }
        }
        Ok(())
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
    /// Phone pages connected now (sockets that subscribed to no monitor stream).
    pub phones_connected: usize,
    /// Monitor pages connected now (sockets that subscribed to monitor streams).
    pub monitors_connected: usize,
    /// Phones paired (tokens issued and kept).
    pub phones_paired: usize,
}

/// The latest of each state a page shows, sent to a page as it connects.
#[derive(Debug, Default)]
struct Snapshot {
    destinations: Option<ToPage>,
    route: Option<ToPage>,
    position: Option<ToPage>,
    obstacle: Option<ToPage>,
    agents: Option<ToPage>,
}

/// What a page asks of the bus.
#[derive(Debug)]
enum PageEvent {
    Command(Command),
    Ack(PhoneAck),
    Motion { heading: Option<(f32, Option<f32>)>, steps: Option<u64> },
    Destinations,
}

/// What the HTTP handlers share with the bus loop.
struct Bridge {
    user: String,
    started: Instant,
    view: Mutex<BridgeView>,
    pairing: Mutex<Pairing>,
    snapshot: Mutex<Snapshot>,
    to_pages: broadcast::Sender<Arc<str>>,
    /// The latest of each monitor stream, for a page that subscribes.
    monitor: Mutex<MonitorState>,
    /// Monitor messages with their stream; each session passes on those it asked for.
    to_monitors: broadcast::Sender<MonitorNews>,
    to_bus: mpsc::Sender<PageEvent>,
    health: Arc<Health>,
    key_ws: String,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Bridge {
    fn now_ms(&self) -> u64 {
        self.started.elapsed().as_millis() as u64
    }

    /// Send `m` to every page, and keep it as the state a new page starts from.
    fn publish(&self, m: ToPage) {
        let text: Arc<str> = protocol::to_text(&m).into();
        {
            let mut s = lock(&self.snapshot);
            let slot = match &m {
                ToPage::Destinations { .. } => Some(&mut s.destinations),
                ToPage::Route { .. } => Some(&mut s.route),
                ToPage::Position { .. } => Some(&mut s.position),
                ToPage::Obstacle { .. } => Some(&mut s.obstacle),
                ToPage::Agents { .. } => Some(&mut s.agents),
                _ => None,
            };
            if let Some(slot) = slot {
                if slot.as_ref() == Some(&m) {
                    return; // nothing new for the pages
                }
                *slot = Some(m);
            }
        }
        // no page connected is not an error
        let _ = self.to_pages.send(text);
    }

    /// Keep `m` as its stream's state and send it to the monitors that asked for it.
    fn publish_monitor(&self, m: ToMonitor) {
        lock(&self.monitor).keep(&m);
        let Some(stream) = m.stream() else { return };
        // nothing is turned into text for no monitor
        if self.to_monitors.receiver_count() > 0 {
            let _ = self.to_monitors.send((stream, monitor::to_text(&m).into()));
        }
    }
}

/// A monitor message and the stream it belongs to.
type MonitorNews = (Stream, Arc<str>);

const PAGE: &str = include_str!("../static/index.html");
const MONITOR_PAGE: &str = include_str!("../static/monitor.html");

async fn page() -> Response {
    ([(header::CACHE_CONTROL, "no-store")], Html(PAGE)).into_response()
}

async fn monitor_page() -> Response {
    ([(header::CACHE_CONTROL, "no-store")], Html(MONITOR_PAGE)).into_response()
}

async fn health_view(State(bridge): State<Arc<Bridge>>) -> Json<BridgeView> {
    let mut v = lock(&bridge.view).clone();
    v.phones_paired = lock(&bridge.pairing).paired();
    Json(v)
}

#[derive(Deserialize)]
struct PairRequest {
    code: String,
}

fn json_error(status: StatusCode, message: &str, retry_after_s: Option<u64>) -> Response {
    let body = serde_json::json!({ "error": message, "retry_after_s": retry_after_s });
    (status, Json(body)).into_response()
}

async fn pair(
    State(bridge): State<Arc<Bridge>>,
    body: Result<Json<PairRequest>, axum::extract::rejection::JsonRejection>,
) -> Response {
    let Ok(Json(request)) = body else {
        bridge.health.reject("/pair", "bad_json", &"pairing request is not {\"code\": \"...\"}");
        return json_error(StatusCode::BAD_REQUEST, "Send the pairing code as {\"code\": \"123456\"}.", None);
    };
    let now = bridge.now_ms();
    let attempt = lock(&bridge.pairing).attempt(&request.code, now);
    match attempt {
        Ok(Attempt::Paired(token)) => {
            tracing::info!("a phone paired");
            Json(serde_json::json!({ "token": token })).into_response()
        }
        Ok(Attempt::Wrong { retry_after_s }) => {
            bridge.health.reject("/pair", "wrong_code", &"a wrong pairing code");
            let message = if retry_after_s == 0 {
                "Wrong pairing code. Check the code the bridge said and try again.".to_string()
            } else {
                format!("Wrong pairing code. Try again in {retry_after_s} seconds.")
            };
            json_error(StatusCode::FORBIDDEN, &message, Some(retry_after_s))
        }
        Ok(Attempt::TooSoon { retry_after_s }) => {
            bridge.health.reject("/pair", "too_soon", &"a pairing try while waiting");
            let message = format!("Too many wrong codes. Try again in {retry_after_s} seconds.");
            json_error(StatusCode::TOO_MANY_REQUESTS, &message, Some(retry_after_s))
        }
        Err(e) => {
            tracing::error!("pairing: {e:#}");
            json_error(StatusCode::INTERNAL_SERVER_ERROR, &format!("The bridge could not keep the pairing: {e}"), None)
        }
    }
}

#[derive(Deserialize)]
struct WsQuery {
    token: Option<String>,
}

async fn ws(State(bridge): State<Arc<Bridge>>, Query(q): Query<WsQuery>, upgrade: WebSocketUpgrade) -> Response {
    let token = q.token.unwrap_or_default();
    if !lock(&bridge.pairing).is_paired(&token) {
        bridge.health.reject(&bridge.key_ws, "not_paired", &"a socket without a paired token");
        return json_error(StatusCode::UNAUTHORIZED, "This phone is not paired: enter the pairing code first.", None);
    }
    upgrade
        .max_message_size(MAX_MESSAGE_BYTES)
        .max_frame_size(MAX_MESSAGE_BYTES)
        .on_upgrade(move |socket| page_session(socket, bridge))
}

/// A token bucket: `rate` a second, at most `burst` at once.
struct RateLimit {
    tokens: f64,
    last: Instant,
}

impl RateLimit {
    fn new() -> Self {
        Self { tokens: COMMAND_BURST, last: Instant::now() }
    }

    fn allow(&mut self, now: Instant) -> bool {
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        self.tokens = (self.tokens + dt * COMMANDS_PER_S).min(COMMAND_BURST);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

async fn send(socket: &mut WebSocket, m: &ToPage) -> bool {
    socket.send(WsMessage::Text(protocol::to_text(m).into())).await.is_ok()
}

fn wall_ms() -> f64 {
    bus::now_ns() as f64 / 1e6
}

/// The next monitor message of a socket that subscribed; never, for one that did not.
async fn monitor_news(
    news: &mut Option<broadcast::Receiver<MonitorNews>>,
) -> Result<MonitorNews, broadcast::error::RecvError> {
    match news {
        Some(news) => news.recv().await,
        None => std::future::pending().await,
    }
}

/// One page's socket: the bus's news out, the page's commands and answers in; and, once
/// it subscribed, the monitor streams it asked for.
async fn page_session(mut socket: WebSocket, bridge: Arc<Bridge>) {
    let mut news = bridge.to_pages.subscribe();
    lock(&bridge.view).phones_connected += 1;
    tracing::info!("phone page connected");
    let mut greeting = vec![ToPage::Hello { user: bridge.user.clone() }];
    {
        let s = lock(&bridge.snapshot);
        greeting
            .extend([&s.destinations, &s.agents, &s.position, &s.route, &s.obstacle].into_iter().flatten().cloned());
    }
    let mut open = true;
    for m in &greeting {
        open &= send(&mut socket, m).await;
    }
    if lock(&bridge.snapshot).destinations.is_none() {
        let _ = bridge.to_bus.try_send(PageEvent::Destinations);
    }
    let mut clock = ClockOffset::default();
    let mut limit = RateLimit::new();
    let mut tick = tokio::time::interval(CLOCK_PERIOD);
    let mut streams = StreamSet::default();
    let mut monitor_rx: Option<broadcast::Receiver<MonitorNews>> = None;
    while open {
        tokio::select! {
            incoming = socket.recv() => {
                let text = match incoming {
                    None | Some(Ok(WsMessage::Close(_))) => break,
                    Some(Err(e)) => {
                        // too big a frame, a broken connection: the socket is gone
                        bridge.health.reject(&bridge.key_ws, "bad_frame", &e);
                        tracing::info!("phone page socket closed: {e}");
                        break;
                    }
                    Some(Ok(WsMessage::Text(t))) => t,
                    Some(Ok(WsMessage::Binary(_))) => {
                        bridge.health.reject(&bridge.key_ws, "binary", &"a binary frame");
                        let m = ToPage::Error { message: "The bridge reads JSON text messages only.".into() };
                        open = send(&mut socket, &m).await;
                        continue;
                    }
                    Some(Ok(_)) => continue, // ping and pong are the socket's own
                };
                match from_page(&bridge, text.as_str(), &mut clock, &mut limit) {
                    None => {}
                    Some(Reply::Page(reply)) => open = send(&mut socket, &reply).await,
                    Some(Reply::Subscribe(asked)) => {
                        count_role(&bridge, streams, asked);
                        streams = asked;
                        // subscribe before taking the state: a message between the two is
                        // sent twice, never lost
                        monitor_rx = if asked.is_empty() {
                            None
                        } else {
                            Some(monitor_rx.take().unwrap_or_else(|| bridge.to_monitors.subscribe()))
                        };
                        let state = lock(&bridge.monitor).greeting(asked);
                        for m in &state {
                            if open {
                                open = socket.send(WsMessage::Text(monitor::to_text(m).into())).await.is_ok();
                            }
                        }
                    }
                }
            }
            news = news.recv() => match news {
                Ok(text) => open = socket.send(WsMessage::Text(text.as_ref().into())).await.is_ok(),
                Err(broadcast::error::RecvError::Lagged(n)) => {
                    // a page too slow to read: what it missed is counted, not queued forever
                    bridge.health.reject(&bridge.key_ws, "page_lagged", &format!("{n} messages not sent to a slow page"));
                }
                Err(broadcast::error::RecvError::Closed) => break,
            },
            item = monitor_news(&mut monitor_rx) => match item {
                Ok((stream, text)) => if streams.contains(stream) {
                    open = socket.send(WsMessage::Text(text.as_ref().into())).await.is_ok();
                },
                Err(broadcast::error::RecvError::Lagged(n)) => {
                    bridge.health.reject(&bridge.key_ws, "monitor_lagged", &format!("{n} messages not sent to a slow monitor page"));
                }
                Err(broadcast::error::RecvError::Closed) => break,
            },
            _ = tick.tick() => open = send(&mut socket, &ToPage::Clock { t: wall_ms() }).await,
        }
    }
    count_role(&bridge, streams, StreamSet::default());
    lock(&bridge.view).phones_connected -= 1;
    tracing::info!("phone page disconnected");
}

/// A socket that subscribes to monitor streams counts as a monitor, not a phone (and
/// back when it asks for none).
fn count_role(bridge: &Bridge, was: StreamSet, now: StreamSet) {
    let mut v = lock(&bridge.view);
    match (was.is_empty(), now.is_empty()) {
        (true, false) => {
            v.phones_connected -= 1;
            v.monitors_connected += 1;
        }
        (false, true) => {
            v.phones_connected += 1;
            v.monitors_connected -= 1;
        }
        _ => {}
    }
}

/// What a session does with a page's message.
enum Reply {
    /// Send the page this.
    Page(ToPage),
    /// Send the page these monitor streams from now on (and their state at once).
    Subscribe(StreamSet),
}

/// Act on one text frame; the reply for the page, if any.
fn from_page(bridge: &Bridge, text: &str, clock: &mut ClockOffset, limit: &mut RateLimit) -> Option<Reply> {
    let message = match protocol::parse(text) {
        Ok(m) => m,
        Err(refusal) => {
            bridge.health.reject(&bridge.key_ws, refusal.kind, &refusal.message);
            return Some(Reply::Page(ToPage::Error { message: refusal.message }));
        }
    };
    let event = match message {
        FromPage::Command(c) => {
            if !limit.allow(Instant::now()) {
                bridge.health.reject(&bridge.key_ws, "rate_limited", &format!("{} command", c.verb()));
                let message = format!("Too many commands: {} was not sent. Wait a moment.", c.verb());
                return Some(Reply::Page(ToPage::Error { message }));
            }
            PageEvent::Command(c)
        }
        FromPage::Subscribe(streams) => {
            // each answer carries the maps: as limited as commands
            if !limit.allow(Instant::now()) {
                bridge.health.reject(&bridge.key_ws, "rate_limited", &"subscribe");
                let message = "Too many subscriptions at once: that one was not taken. Wait a moment.".to_string();
                return Some(Reply::Page(ToPage::Error { message }));
            }
            return Some(Reply::Subscribe(streams));
        }
        FromPage::Ack { id, event, t_ms } => {
            let at_ns = clock.to_bridge_ns(t_ms, bus::now_ns());
            PageEvent::Ack(PhoneAck { id, event, at_ns })
        }
        FromPage::Clock { t_ms, page_t_ms } => {
            clock.observe(t_ms, page_t_ms, wall_ms());
            return None;
        }
        FromPage::Heading { deg, accuracy_deg } => {
            PageEvent::Motion { heading: Some((deg, accuracy_deg)), steps: None }
        }
        FromPage::Steps { count } => PageEvent::Motion { heading: None, steps: Some(count) },
        FromPage::Destinations => PageEvent::Destinations,
    };
    if bridge.to_bus.try_send(event).is_err() {
        bridge.health.reject(&bridge.key_ws, "queue_full", &"page event dropped: the bus side is behind");
        return Some(Reply::Page(ToPage::Error {
            message: "The bridge is busy: that was not sent. Try again.".into(),
        }));
    }
    None
}

/// This machine's address on the LAN (the one a default route would use), if any.
fn lan_ip() -> Option<IpAddr> {
    let probe = std::net::UdpSocket::bind("0.0.0.0:0").ok()?;
    // connecting a UDP socket sends nothing: it only picks the route
    probe.connect("192.0.2.1:9").ok()?;
    probe.local_addr().ok().map(|a| a.ip()).filter(|ip| !ip.is_unspecified() && !ip.is_loopback())
}

/// The address to print for the phone.
fn page_url(scheme: &str, bound: SocketAddr) -> String {
    let ip = if bound.ip().is_unspecified() { lan_ip().unwrap_or(IpAddr::from([127, 0, 0, 1])) } else { bound.ip() };
    match ip {
        IpAddr::V6(v6) => format!("{scheme}://[{v6}]:{}/", bound.port()),
        IpAddr::V4(v4) => format!("{scheme}://{v4}:{}/", bound.port()),
    }
}

fn qr(text: &str) -> Option<String> {
    let code = qrcode::QrCode::new(text.as_bytes()).ok()?;
    Some(code.render::<qrcode::render::unicode::Dense1x2>().quiet_zone(true).build())
}

/// The code spoken digit by digit.
fn spoken_code(code: &str) -> String {
    let digits: Vec<String> = code.chars().map(|c| c.to_string()).collect();
    format!("Phone bridge ready. Pairing code {}.", digits.join(" "))
}

/// Run the bridge until `shutdown`. Reports the bound address through `bound` (the
/// demo and tests ask for port 0 and need to know which port they got).
pub async fn run(
    config: PhoneConfig,
    shutdown: Shutdown,
    bound: Option<tokio::sync::oneshot::Sender<SocketAddr>>,
) -> anyhow::Result<()> {
    config.check()?;
    let keys = config.bus.keys()?;
    std::fs::create_dir_all(&config.state_dir)
        .with_context(|| format!("cannot make the state directory {}", config.state_dir.display()))?;
    let code = config.pairing_code.clone().unwrap_or_else(crate::pairing::new_code);
    let pairing = Pairing::with_file(code, &config.state_dir.join("paired-phones"))?;
    let code = pairing.code().to_string();

    let (scheme, addr, tls) = match config.serve {
        Serve::Http(addr) => ("http", addr, None),
        Serve::Https(addr) => {
            let given = config.tls.as_ref().map(|(c, k)| (c.as_path(), k.as_path()));
            let extra: Vec<IpAddr> =
                lan_ip().into_iter().chain([addr.ip()]).filter(|ip| !ip.is_unspecified()).collect();
            let files = crate::tls::certificate(given, &config.state_dir, &extra)?;
            if files.made {
                tracing::info!("made a self-signed certificate {}", files.cert.display());
            }
            ("https", addr, Some(crate::tls::server_config(&files)?))
        }
    };
    let listener = tokio::net::TcpListener::bind(addr).await.with_context(|| {
        format!("cannot serve the phone page on {addr} (port taken? choose another with --{scheme})")
    })?;
    let local = listener.local_addr()?;

    let session = bus::open_session(&config.bus).await?;
    let health = Health::new(AGENT);
    let mut health_task = health.spawn(session.clone(), keys.clone(), config.health_period, shutdown.clone());
    let (to_pages, _) = broadcast::channel(256);
    let (to_monitors, _) = broadcast::channel(MONITOR_QUEUE);
    let (to_bus, mut page_events) = mpsc::channel(256);
    let maps = config
        .map
        .as_ref()
        .map(|b| b.floors().iter().map(|f| monitor::floor_map(f, monitor::MAX_MAP_CELLS)).collect())
        .unwrap_or_default();
    let regions = monitor::regions(&config.perception.ficf, &config.perception.cacf);
    let bridge = Arc::new(Bridge {
        user: config.bus.user.clone(),
        started: Instant::now(),
        view: Mutex::new(BridgeView { user: config.bus.user.clone(), ..Default::default() }),
        pairing: Mutex::new(pairing),
        snapshot: Mutex::new(Snapshot::default()),
        to_pages,
        monitor: Mutex::new(MonitorState::new(regions, maps)),
        to_monitors,
        to_bus,
        health: health.clone(),
        key_ws: format!("{}/phone/ws", keys.prefix()),
    });

    let hazards = Subscriber::<Hazard>::declare(&session, keys.hazard(), true, &health).await?;
    let routes = Subscriber::<RouteState>::declare(&session, keys.route_state(), true, &health).await?;
    let poses = Subscriber::<Pose>::declare(&session, keys.pose(), true, &health).await?;
    let request_age = Duration::from_secs(2);
    let haptic =
        Subscriber::<PhoneHaptic>::declare_fresh(&session, keys.phone_haptic(), false, request_age, &health).await?;
    let speech =
        Subscriber::<PhoneSpeech>::declare_fresh(&session, keys.phone_speech(), false, request_age, &health).await?;
    let mut acks =
        Publisher::<PhoneAck>::declare(&session, keys.phone_ack(), AGENT, Lane::Events, Some(&health)).await?;
    let mut motion =
        Publisher::<PhoneMotion>::declare(&session, keys.motion("phone"), AGENT, Lane::Events, Some(&health)).await?;
    let mut commands: HashMap<&'static str, Publisher<Command>> = HashMap::new();
    // what only the monitor page shows (the speech subscription is declared before the
    // pairing code is said, so the monitor lists that too)
    let scans = Subscriber::<Scan>::declare(&session, keys.scan(), true, &health).await?;
    let intents = Subscriber::<HapticIntent>::declare(&session, keys.haptic(), true, &health).await?;
    let truths = Subscriber::<GroundTruth>::declare(&session, keys.truth_any(), true, &health).await?;
    let cameras = Subscriber::<CameraPlace>::declare(&session, keys.camera_place(), true, &health).await?;
    let utterances = Subscriber::<SpeechIntent>::declare(&session, keys.speech(), false, &health).await?;
    let agent_stats = Subscriber::<HealthStats>::declare(&session, keys.health_any(), false, &health).await?;
    let liveliness = session
        .liveliness()
        .declare_subscriber(keys.health_any())
        .history(true)
        .await
        .map_err(|e| anyhow!("cannot watch liveliness: {e}"))?;

    let app = Router::new()
        .route("/", get(page))
        .route("/monitor", get(monitor_page))
        .route("/health", get(health_view))
        .route("/pair", post(pair).layer(DefaultBodyLimit::max(1024)))
        .route("/ws", get(ws))
        .with_state(bridge.clone());
    let server_shutdown = shutdown.clone();
    let server = match tls {
        None => tokio::spawn(async move {
            axum::serve(listener, app).with_graceful_shutdown(async move { server_shutdown.triggered().await }).await
        }),
        Some(tls) => {
            let listener = crate::tls::TlsListener::new(listener, tls)?;
            tokio::spawn(async move {
                axum::serve(listener, app)
                    .with_graceful_shutdown(async move { server_shutdown.triggered().await })
                    .await
            })
        }
    };
    let url = page_url(scheme, local);
    tracing::info!("phone bridge serving {url} for user {}", config.bus.user);
    if let Some(tx) = bound {
        let _ = tx.send(local);
    }
    if config.announce {
        let qr = qr(&url).unwrap_or_default();
        println!(
            "wearnav phone bridge for user {}: open the page on the phone\n{qr}\nurl: {url}\npairing code: {code}",
            config.bus.user
        );
        let mut say =
            Publisher::<SpeechIntent>::declare(&session, keys.speech(), AGENT, Lane::Events, Some(&health)).await?;
        let intent = SpeechIntent {
            text: spoken_code(&code),
            priority: Priority::Message,
            interrupt: false,
            ttl_ms: 10_000,
            dedup_key: String::new(),
            notice: false,
        };
        if let Err(e) = say.put(bus::now_ns(), &intent).await {
            tracing::warn!("cannot have the pairing code spoken: {e:#}");
        }
    }
    health.set_status(true, format!("serving {url}"));

    let (answers_tx, mut answers) = mpsc::channel::<anyhow::Result<Result<Destinations, String>>>(4);
    let ask_destinations = |session: &zenoh::Session| {
        let (session, tx, selector) = (session.clone(), answers_tx.clone(), keys.query("destinations"));
        tokio::spawn(async move {
            let _ = tx.send(bus::query::get::<Destinations>(&session, &selector, Duration::from_secs(3)).await).await;
        });
    };
    ask_destinations(&session);
    let mut retry = tokio::time::interval(Duration::from_secs(10));
    let mut phone_motion = PhoneMotion { heading_deg: None, accuracy_deg: None, steps: 0 };

    let failure = loop {
        tokio::select! {
            _ = shutdown.triggered() => break None,
            e = health_task.failed() => break Some(e),
            Some(h) = hazards.recv() => {
                {
                    let mut v = lock(&bridge.view);
                    v.hazards += 1;
                    v.last_rumble = Some(format!("{:?}", h.body.rumble).to_lowercase());
                    v.last_ground = Some(format!("{:?}", h.body.ground).to_lowercase());
                    v.last_hazard_age_ms = Some(h.age_ms());
                }
                bridge.publish(protocol::obstacle(&h.body));
                bridge.publish_monitor(monitor::hazard(&h.body, h.header.seq, h.header.capture_ns, h.age_ms()));
            }
            Some(r) = routes.recv() => {
                if let Some(m) = protocol::route(&r.body) {
                    bridge.publish(m);
                }
                bridge.publish_monitor(monitor::route_path(&r.body));
            }
            Some(p) = poses.recv() => {
                bridge.publish(protocol::position(&p.body));
                bridge.publish_monitor(monitor::pose(&p.body, p.header.capture_ns));
            }
            Some(s) = scans.recv() => bridge.publish_monitor(monitor::scan(&s.body, s.header.seq, s.header.capture_ns)),
            Some(i) = intents.recv() => bridge.publish_monitor(monitor::haptic(&i.body, i.header.capture_ns)),
            Some(t) = truths.recv() => bridge.publish_monitor(monitor::truth(&t.body, t.header.capture_ns)),
            Some(c) = cameras.recv() => bridge.publish_monitor(monitor::camera(&c.body, c.header.capture_ns)),
            Some(u) = utterances.recv() => bridge.publish_monitor(monitor::utterance(&u.body, u.header.capture_ns)),
            Some(a) = agent_stats.recv() => {
                let alive = lock(&bridge.view).agents_alive.contains(&a.body.agent);
                bridge.publish_monitor(monitor::health(&a.body, alive, keys.prefix(), a.age_ms()));
            }
            Some(h) = haptic.recv() => bridge.publish(protocol::vibrate(&h.body)),
            Some(s) = speech.recv() => match &s.body {
                // no phone page to say it: answered at once, so the feedback agent's
                // queue goes on rather than wait for a start that cannot come (what
                // waited behind such words was once said seconds late, or not at all)
                PhoneSpeech::Say { id, .. } if lock(&bridge.view).phones_connected == 0 => {
                    let now = bus::now_ns();
                    let failed = PhoneAck { id: *id, event: PhoneEvent::Failed { reason: NO_PAGE.into() }, at_ns: now };
                    if let Err(e) = acks.put(now, &failed).await {
                        tracing::warn!("cannot say that no phone page is connected: {e:#}");
                    }
                }
                said => bridge.publish(protocol::speech(said)),
            },
            Some(event) = page_events.recv() => match event {
                PageEvent::Command(c) => {
                    let verb = c.verb();
                    if !commands.contains_key(verb) {
                        let p = Publisher::<Command>::declare(&session, keys.cmd(verb), AGENT, Lane::Events, Some(&health)).await?;
                        commands.insert(verb, p);
                    }
                    if let Some(p) = commands.get_mut(verb) {
                        if let Err(e) = p.put(bus::now_ns(), &c).await {
                            bridge.publish(ToPage::Error { message: format!("The {verb} command could not be sent: {e}") });
                        }
                    }
                }
                PageEvent::Ack(a) => {
                    if let Err(e) = acks.put(bus::now_ns(), &a).await {
                        tracing::warn!("cannot pass on the phone's acknowledgement: {e:#}");
                    }
                }
                PageEvent::Motion { heading, steps } => {
                    if let Some((deg, accuracy)) = heading {
                        phone_motion.heading_deg = Some(deg);
                        phone_motion.accuracy_deg = accuracy;
                    }
                    if let Some(s) = steps {
                        phone_motion.steps = s;
                    }
                    if let Err(e) = motion.put(bus::now_ns(), &phone_motion).await {
                        tracing::warn!("cannot publish the phone's heading: {e:#}");
                    }
                }
                PageEvent::Destinations => ask_destinations(&session),
            },
            Some(answer) = answers.recv() => match answer {
                Ok(Ok(d)) => bridge.publish(protocol::destinations(&d)),
                Ok(Err(why)) => tracing::info!("no destinations yet: {why}"),
                Err(e) => tracing::debug!("no destinations yet: {e:#}"),
            },
            _ = retry.tick() => {
                if lock(&bridge.snapshot).destinations.is_none() {
                    ask_destinations(&session);
                }
            }
            Ok(sample) = liveliness.recv_async() => {
                let Some(agent) = keys.agent_of(sample.key_expr().as_str()) else { continue };
                let present = sample.kind() == SampleKind::Put;
                let alive = {
                    let mut v = lock(&bridge.view);
                    if present {
                        v.agents_alive.insert(agent.to_string());
                    } else {
                        v.agents_alive.remove(agent);
                    }
                    v.agents_alive.iter().cloned().collect()
                };
                bridge.publish(ToPage::Agents { alive });
                let now = lock(&bridge.monitor).set_alive(agent, present);
                bridge.publish_monitor(now);
            }
        }
    };
    if failure.is_some() {
        server.abort();
    } else {
        match server.await {
            Ok(Ok(())) => {}
            Ok(Err(e)) => tracing::warn!("phone page server: {e}"),
            Err(e) => tracing::warn!("phone page server task: {e}"),
        }
    }
    if let Some(e) = failure {
        return Err(e);
    }
    health_task.join().await?;
    session.close().await.map_err(|e| anyhow!("{e}")).context("closing the Zenoh session")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_http_is_refused_beyond_loopback() {
        let mut c = PhoneConfig::new(BusOptions::for_user("t"));
        c.serve = Serve::Http("0.0.0.0:8080".parse().unwrap());
        let e = c.check().unwrap_err().to_string();
        assert!(e.contains("plain HTTP on 0.0.0.0:8080") && e.contains("--https"), "{e}");
        c.serve = Serve::Http("127.0.0.1:8080".parse().unwrap());
        assert!(c.check().is_ok());
        c.serve = Serve::Https("0.0.0.0:8443".parse().unwrap());
        assert!(c.check().is_ok());
        c.pairing_code = Some("12345".into());
        assert!(c.check().unwrap_err().to_string().contains("six digits"));
    }

    #[test]
    fn commands_are_limited_to_a_burst_then_a_steady_rate() {
        let mut l = RateLimit::new();
        let t0 = l.last;
        let allowed = (0..20).filter(|_| l.allow(t0)).count();
        assert_eq!(allowed, COMMAND_BURST as usize);
        assert!(!l.allow(t0 + Duration::from_millis(100)));
        assert!(l.allow(t0 + Duration::from_millis(300)), "one more after 1/{COMMANDS_PER_S} s");
    }

    #[test]
    fn the_code_is_spoken_digit_by_digit() {
        assert_eq!(spoken_code("042917"), "Phone bridge ready. Pairing code 0 4 2 9 1 7.");
    }
}
