//! The bridge serves its page and a health view that reflects the bus.

mod common;

use std::time::Duration;

use bus::{BusOptions, Lane, Publisher, Shutdown};
use common::get;
use schemas::{CostFunction, GroundState, Hazard, Rumble, SideCosts};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// The bridge's state folder for one test, removed when the test ends (failed too).
fn state_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("wearnav-bridge-{name}-")).tempdir().unwrap()
}

fn hazard(rumble: Rumble) -> Hazard {
    Hazard {
        frame_seq: 1,
        ficf: SideCosts::default(),
        cacf: SideCosts::default(),
        active: CostFunction::Ficf,
        rumble,
        ground: GroundState::Found,
        plane_camera: [0.0, -1.0, 0.0, 1.0],
        nearest_m: 0.7,
        nearest_bearing_deg: 0.0,
        ttc_s: None,
        dropoff_ahead: false,
        turn_ahead: false,
        body_turn_deg_s: None,
        predictive: false,
        gravity: true,
        latency: vec![],
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn page_is_served_and_health_shows_agents_and_the_last_hazard() {
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut hub = BusOptions::for_user("phone-test");
    hub.listen = vec![endpoint.clone()];
    hub.no_multicast = true;
    let session = bus::open_session(&hub).await.unwrap();

    let mut bridge_bus = BusOptions::for_user("phone-test");
    bridge_bus.connect = vec![endpoint];
    bridge_bus.no_multicast = true;
    let mut config = phone_bridge::PhoneConfig::new(bridge_bus);
    config.serve = phone_bridge::Serve::Http("127.0.0.1:0".parse().unwrap());
    let dir = state_dir("page");
    config.state_dir = dir.path().to_path_buf();
    config.announce = false;
    let shutdown = Shutdown::new();
    let (tx, rx) = tokio::sync::oneshot::channel();
    let bridge = tokio::spawn(phone_bridge::run(config, shutdown.clone(), Some(tx)));
    let addr = tokio::time::timeout(Duration::from_secs(10), rx).await.unwrap().unwrap();

    let (status, page) = get(addr, "/").await;
    assert_eq!(status, 200);
    assert!(page.contains("<title>wearnav</title>") && page.contains("aria-live"), "{page}");

    let keys = hub.keys().unwrap();
    let _token = session.liveliness().declare_token(keys.health("compute-agent")).await.unwrap();
    let mut publisher =
        Publisher::<Hazard>::declare(&session, keys.hazard(), "test", Lane::Perception, None).await.unwrap();
    let mut view = serde_json::Value::Null;
    for _ in 0..50 {
        publisher.put(bus::now_ns(), &hazard(Rumble::Left)).await.unwrap();
        tokio::time::sleep(Duration::from_millis(100)).await;
        let (status, body) = get(addr, "/health").await;
        assert_eq!(status, 200);
        view = serde_json::from_str(&body).unwrap();
        if view["last_rumble"] == "left" && view["agents_alive"].to_string().contains("compute-agent") {
            break;
        }
    }
    assert_eq!(view["last_rumble"], "left", "{view}");
    assert_eq!(view["last_ground"], "found", "{view}");
    assert!(view["agents_alive"].to_string().contains("compute-agent"), "{view}");
    assert!(view["agents_alive"].to_string().contains("phone-bridge"), "{view}");

    shutdown.trigger();
    tokio::time::timeout(Duration::from_secs(5), bridge).await.unwrap().unwrap().unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn https_serves_the_page_with_the_certificate_it_made_and_keeps() {
    use rustls::pki_types::{pem::PemObject, CertificateDer, ServerName};
    let mut bus = BusOptions::for_user("https-test");
    bus.no_multicast = true;
    let mut config = phone_bridge::PhoneConfig::new(bus);
    config.serve = phone_bridge::Serve::Https("127.0.0.1:0".parse().unwrap());
    let dir = state_dir("https");
    config.state_dir = dir.path().to_path_buf();
    config.announce = false;
    let shutdown = Shutdown::new();
    let (tx, rx) = tokio::sync::oneshot::channel();
    let bridge = tokio::spawn(phone_bridge::run(config, shutdown.clone(), Some(tx)));
    let addr = tokio::time::timeout(Duration::from_secs(10), rx).await.unwrap().unwrap();

    // a client that trusts only the certificate the bridge made
    let cert =
        CertificateDer::from_pem_file(dir.path().join("phone-bridge.crt")).expect("the bridge kept its certificate");
    let mut roots = rustls::RootCertStore::empty();
    roots.add(cert).unwrap();
    let provider = std::sync::Arc::new(rustls::crypto::ring::default_provider());
    let client = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .unwrap()
        .with_root_certificates(roots)
        .with_no_client_auth();
    let connector = tokio_rustls::TlsConnector::from(std::sync::Arc::new(client));
    let tcp = tokio::net::TcpStream::connect(addr).await.unwrap();
    let mut tls = connector.connect(ServerName::try_from("localhost").unwrap(), tcp).await.expect("TLS handshake");
    tls.write_all(b"GET / HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n").await.unwrap();
    let mut response = Vec::new();
    let _ = tls.read_to_end(&mut response).await; // a close without close_notify is fine here
    let response = String::from_utf8_lossy(&response);
    assert!(response.starts_with("HTTP/1.1 200"), "{response}");
    assert!(response.contains("<title>wearnav</title>"), "{response}");
    // plain HTTP on the TLS port gets no page
    let (status, _) = get(addr, "/").await;
    assert_ne!(status, 200);

    shutdown.trigger();
    tokio::time::timeout(Duration::from_secs(5), bridge).await.unwrap().unwrap().unwrap();
}
