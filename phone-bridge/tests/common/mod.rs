//! What the bridge's tests share: plain HTTP requests, pairing, a WebSocket client and
//! waiting for one type of message on it.
#![allow(dead_code)] // each test file uses some of these

use std::net::SocketAddr;
use std::time::Duration;

use futures_util::StreamExt;
use serde_json::Value;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::Message;

/// Send `request` as it is; the status and the body.
pub async fn http(addr: SocketAddr, request: &str) -> (u16, String) {
    let mut stream = tokio::net::TcpStream::connect(addr).await.expect("connect to the bridge");
    stream.write_all(request.as_bytes()).await.unwrap();
    let mut response = String::new();
    stream.read_to_string(&mut response).await.unwrap();
    let status = response.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    let body = response.split("\r\n\r\n").nth(1).unwrap_or("").to_string();
    (status, body)
}

/// `GET path`: the status and the body.
pub async fn get(addr: SocketAddr, path: &str) -> (u16, String) {
    http(addr, &format!("GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")).await
}

/// `GET /health` as JSON.
pub async fn health(addr: SocketAddr) -> Value {
    let (status, body) = get(addr, "/health").await;
    assert_eq!(status, 200, "{body}");
    serde_json::from_str(&body).expect("/health is JSON")
}

/// `POST /pair` with `code`: the status and the JSON answer.
pub async fn pair(addr: SocketAddr, code: &str) -> (u16, Value) {
    let body = format!(r#"{{"code":"{code}"}}"#);
    let request = format!(
        "POST /pair HTTP/1.1\r\nHost: localhost\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    );
    let (status, body) = http(addr, &request).await;
    (status, serde_json::from_str(&body).unwrap_or(Value::Null))
}

/// A page's socket.
pub type Socket = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// Open `/ws` with `token`.
pub async fn connect(addr: SocketAddr, token: &str) -> Result<Socket, tokio_tungstenite::tungstenite::Error> {
    tokio_tungstenite::connect_async(format!("ws://{addr}/ws?token={token}")).await.map(|(s, _)| s)
}

/// The next message of `type_` within `within`, skipping others (clock ticks, state).
pub async fn next_of(socket: &mut Socket, type_: &str, within: Duration) -> Value {
    tokio::time::timeout(within, async {
        loop {
            match socket.next().await {
                Some(Ok(Message::Text(t))) => {
                    let v: Value = serde_json::from_str(t.as_str()).expect("the bridge sends JSON");
                    if v["type"] == type_ {
                        return v;
                    }
                }
                Some(Ok(_)) => {}
                other => panic!("socket ended waiting for {type_}: {other:?}"),
            }
        }
    })
    .await
    .unwrap_or_else(|_| panic!("no {type_} message within {within:?}"))
}

/// Every message that arrives within `within`.
pub async fn drain(socket: &mut Socket, within: Duration) -> Vec<Value> {
    let mut out = Vec::new();
    let deadline = tokio::time::Instant::now() + within;
    while let Ok(Some(Ok(m))) = tokio::time::timeout_at(deadline, socket.next()).await {
        if let Message::Text(t) = m {
            out.push(serde_json::from_str(t.as_str()).expect("the bridge sends JSON"));
        }
    }
    out
}
