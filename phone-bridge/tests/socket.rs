//! The bridge's WebSocket and pairing, against a real bridge on a real bus: a socket
//! without a paired token is refused, wrong codes are slowed down, bad messages get a
//! clear error and are not forwarded, commands are rate-limited, an oversized frame
//! closes only that socket, and requests and acknowledgements cross between the JSON
//! the page speaks and the wire schemas.

mod common;

use std::time::Duration;

use bus::{BusOptions, Health, Lane, Publisher, Shutdown, Subscriber};
use common::{connect, next_of, pair};
use futures_util::{SinkExt, StreamExt};
use schemas::{Command, PhoneAck, PhoneEvent, PhoneHaptic, PhoneSpeech, Priority};
use serde_json::Value;
use tokio_tungstenite::tungstenite::Message;

const CODE: &str = "424242";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_socket_needs_pairing_refuses_bad_input_and_carries_requests_and_acks() {
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut hub = BusOptions::for_user("socket-test");
    hub.listen = vec![endpoint.clone()];
    hub.no_multicast = true;
    let session = bus::open_session(&hub).await.unwrap();
    let keys = hub.keys().unwrap();
    let health = Health::new("test");
    let commands = Subscriber::<Command>::declare(&session, keys.cmd_any(), false, &health).await.unwrap();
    let acks = Subscriber::<PhoneAck>::declare(&session, keys.phone_ack(), false, &health).await.unwrap();
    let mut vibrate =
        Publisher::<PhoneHaptic>::declare(&session, keys.phone_haptic(), "test", Lane::RealTime, None).await.unwrap();
    let mut speech =
        Publisher::<PhoneSpeech>::declare(&session, keys.phone_speech(), "test", Lane::Events, None).await.unwrap();
    let say =
        |id: u64| PhoneSpeech::Say { id, text: "Turn left.".into(), priority: Priority::Message, interrupt: true };

    let mut bus = BusOptions::for_user("socket-test");
    bus.connect = vec![endpoint];
    bus.no_multicast = true;
    let mut config = phone_bridge::PhoneConfig::new(bus);
    config.serve = phone_bridge::Serve::Http("127.0.0.1:0".parse().unwrap());
    let dir = tempfile::Builder::new().prefix("wearnav-bridge-socket-").tempdir().unwrap();
    config.state_dir = dir.path().to_path_buf();
    config.announce = false;
    config.pairing_code = Some(CODE.into());
    let shutdown = Shutdown::new();
    let (tx, rx) = tokio::sync::oneshot::channel();
    let bridge = tokio::spawn(phone_bridge::run(config, shutdown.clone(), Some(tx)));
    let addr = tokio::time::timeout(Duration::from_secs(10), rx).await.unwrap().unwrap();

    // words for the phone with no page to say them: answered `Failed` at once, so the
    // feedback agent's queue does not wait for a start that cannot come
    // (said again until the bridge has subscribed; an answer is matched to its own say)
    let mut asked = std::collections::HashMap::new();
    let mut answer = None;
    for id in 1..=20 {
        asked.insert(id, bus::now_ns());
        speech.put(asked[&id], &say(id)).await.unwrap();
        if let Ok(Some(a)) = tokio::time::timeout(Duration::from_millis(250), acks.recv()).await {
            answer = Some((a.body.clone(), asked[&a.body.id]));
            break;
        }
    }
    let (failed, asked_ns) = answer.expect("a say with no page connected was not answered");
    assert_eq!(failed.event, PhoneEvent::Failed { reason: phone_bridge::run::NO_PAGE.into() }, "{failed:?}");
    let answered_ms = (failed.at_ns as f64 - asked_ns as f64) / 1e6;
    assert!((0.0..100.0).contains(&answered_ms), "answered {answered_ms:.1} ms after it was asked");

    // no token, a made-up token: refused before any socket opens
    for token in ["", "0123456789abcdef0123456789abcdef"] {
        let e = connect(addr, token).await.expect_err("refused");
        assert!(e.to_string().contains("401"), "{e}");
    }
    // wrong codes: three at once, then each must wait; a try while waiting is not read
    for k in 0..3 {
        let (status, body) = pair(addr, "000000").await;
        assert_eq!(status, 403, "{body}");
        assert_eq!(body["retry_after_s"], if k < 2 { 0 } else { 1 }, "{body}");
    }
    let (status, body) = pair(addr, CODE).await;
    assert_eq!(status, 429, "even the right code waits: {body}");
    assert!(body["error"].as_str().unwrap().starts_with("Too many wrong codes"), "{body}");
    tokio::time::sleep(Duration::from_millis(1100)).await;
    let (status, body) = pair(addr, CODE).await;
    assert_eq!(status, 200, "{body}");
    let token = body["token"].as_str().unwrap().to_string();
    assert_eq!(token.len(), 32);

    let mut socket = connect(addr, &token).await.expect("a paired token opens the socket");
    let hello = next_of(&mut socket, "hello", Duration::from_secs(5)).await;
    assert_eq!(hello["user"], "socket-test");
    // with a page connected the words go to it, unanswered by the bridge
    speech.put(bus::now_ns(), &say(100)).await.unwrap();
    let said = next_of(&mut socket, "say", Duration::from_secs(5)).await;
    assert_eq!((said["id"].as_u64(), said["text"].as_str()), (Some(100), Some("Turn left.")), "{said}");
    while let Ok(Some(a)) = tokio::time::timeout(Duration::from_millis(300), acks.recv()).await {
        assert!(a.body.id < 100, "the bridge answered words a page was there to say: {:?}", a.body);
    }

    // bad messages: an error each, nothing forwarded, the socket stays open
    for (bad, says) in [
        ("{nope", "not JSON"),
        (r#"{"type":"teleport"}"#, "unknown message type \"teleport\""),
        (r#"{"type":"command","verb":"destination"}"#, "destination needs a \"label\""),
        (r#"{"type":"ack","id":1,"event":"exploded","t":1}"#, "\"event\" must be"),
    ] {
        socket.send(Message::Text(bad.into())).await.unwrap();
        let e = next_of(&mut socket, "error", Duration::from_secs(5)).await;
        assert!(e["message"].as_str().unwrap().contains(says), "{bad}: {e}");
    }
    // a flood of commands: a burst of 10 goes through, the rest are refused
    for _ in 0..15 {
        socket.send(Message::Text(r#"{"type":"command","verb":"repeat"}"#.into())).await.unwrap();
    }
    let mut refused = 0;
    while refused < 5 {
        let e = next_of(&mut socket, "error", Duration::from_secs(5)).await;
        assert!(e["message"].as_str().unwrap().starts_with("Too many commands"), "{e}");
        refused += 1;
    }
    let mut forwarded = 0;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(2);
    while let Ok(Some(c)) = tokio::time::timeout_at(deadline, commands.recv()).await {
        assert_eq!(c.body, Command::Repeat, "only the repeats were forwarded");
        forwarded += 1;
    }
    assert_eq!(forwarded, 10, "the burst, and nothing of the bad messages");

    // a vibration request reaches the page as JSON; the page's ack reaches the bus on
    // the bridge's clock (the page's clock here is 5 s ahead)
    let ahead_ms = 5000.0;
    // answer a clock tick at once, as the page does (not one that waited in the socket)
    let (t, now_ms) = loop {
        let clock = next_of(&mut socket, "clock", Duration::from_secs(3)).await;
        let (t, now_ms) = (clock["t"].as_f64().unwrap(), bus::now_ns() as f64 / 1e6);
        if now_ms - t < 20.0 {
            break (t, now_ms);
        }
    };
    socket
        .send(Message::Text(format!(r#"{{"type":"clock","t":{t},"page_t":{}}}"#, now_ms + ahead_ms).into()))
        .await
        .unwrap();
    let request = PhoneHaptic { id: 77, pattern_ms: vec![60, 40, 60], left: 0.0, right: 0.9 };
    let mut page_saw = Value::Null;
    for _ in 0..20 {
        vibrate.put(bus::now_ns(), &request).await.unwrap();
        if let Ok(v) =
            tokio::time::timeout(Duration::from_millis(250), next_of(&mut socket, "vibrate", Duration::from_secs(1)))
                .await
        {
            page_saw = v;
            break;
        }
    }
    assert_eq!(page_saw, serde_json::json!({"type": "vibrate", "id": 77, "pattern": [60, 40, 60]}));
    let acked_ms = bus::now_ns() as f64 / 1e6;
    let ack = format!(r#"{{"type":"ack","id":77,"event":"vibrated","t":{}}}"#, acked_ms + ahead_ms);
    socket.send(Message::Text(ack.into())).await.unwrap();
    let a = tokio::time::timeout(Duration::from_secs(5), acks.recv()).await.unwrap().unwrap().body;
    assert_eq!((a.id, a.event), (77, PhoneEvent::Vibrated));
    let off_ms = (a.at_ns as f64 / 1e6 - acked_ms).abs();
    assert!(off_ms < 50.0, "the ack is {off_ms:.1} ms off on the bridge's clock");

    // an oversized frame closes that socket only; the bridge goes on serving
    socket.send(Message::Text("x".repeat(20 * 1024).into())).await.ok();
    let closed = tokio::time::timeout(Duration::from_secs(5), async {
        loop {
            match socket.next().await {
                None | Some(Err(_)) | Some(Ok(Message::Close(_))) => break,
                Some(Ok(_)) => {}
            }
        }
    })
    .await;
    assert!(closed.is_ok(), "an oversized frame must close the socket");
    let mut again = connect(addr, &token).await.expect("the bridge still serves");
    next_of(&mut again, "hello", Duration::from_secs(5)).await;
    let view = common::health(addr).await;
    assert_eq!(view["phones_paired"].as_u64(), Some(1), "{view}");

    shutdown.trigger();
    tokio::time::timeout(Duration::from_secs(5), bridge).await.unwrap().unwrap().unwrap();
}
