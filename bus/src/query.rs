//! Queryables (`wearnav/<user>/query/<service>`): a service answers each `get` with one
//! wire message of its schema, or with an error text; and [`get`], the asking side.
//!
//! Queries wait in a bounded inbox for the agent's loop; when it is full a query is
//! answered at once with an error ("busy") and counted, never left to time out.

use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, bail, Context};
use schemas::{Message, Origin};
use tokio::sync::mpsc;
use zenoh::Session;

use crate::stream::encoding_of;
use crate::Health;

/// Queries waiting for the loop; more are answered "busy".
const INBOX: usize = 16;

/// One `get` to answer.
pub struct Query {
    inner: zenoh::query::Query,
}

impl Query {
    /// The service key it was sent to.
    pub fn key(&self) -> &str {
        self.inner.key_expr().as_str()
    }

    /// Selector parameter `name` (`query/route?to=room 204`), `%xx` escapes decoded.
    pub fn parameter(&self, name: &str) -> Option<String> {
        self.inner.parameters().get(name).map(percent_decoded)
    }

    /// Answers with `body`, encoded as a wire message from `sender`.
    pub async fn reply<M: Message>(self, sender: &str, body: &M) -> anyhow::Result<()> {
        let origin = Origin { sender, session: 0 };
        let bytes = schemas::encode(&origin, 0, crate::now_ns(), body);
        let key = self.inner.key_expr().clone();
        self.inner
            .reply(key, bytes)
            .encoding(encoding_of::<M>())
            .await
            .map_err(|e| anyhow!("cannot answer the query on {}: {e}", self.key()))
    }

    /// Answers with an error text.
    pub async fn reply_err(self, text: &str) -> anyhow::Result<()> {
        self.inner
            .reply_err(text.to_string())
            .await
            .map_err(|e| anyhow!("cannot answer the query on {}: {e}", self.key()))
    }
}

/// A service's queryable and its inbox.
pub struct Queryable {
    rx: tokio::sync::Mutex<mpsc::Receiver<Query>>,
    key: String,
    _inner: zenoh::query::Queryable<()>,
}

impl Queryable {
    /// Declares a queryable on `key`; queries beyond the inbox are answered "busy" and
    /// counted in `health` as `queue_full`.
    pub async fn declare(session: &Session, key: String, health: &Arc<Health>) -> anyhow::Result<Self> {
        let (tx, rx) = mpsc::channel(INBOX);
        let health = Arc::clone(health);
        let k = key.clone();
        let inner = session
            .declare_queryable(key.clone())
            .callback(move |q| {
                if let Err(mpsc::error::TrySendError::Full(q) | mpsc::error::TrySendError::Closed(q)) =
                    tx.try_send(Query { inner: q })
                {
                    health.reject(&k, "queue_full", &"too many queries waiting");
                    // answered from here: the waiting side hears why at once
                    let _ = zenoh::Wait::wait(q.inner.reply_err("busy: too many queries waiting, try again"));
                }
            })
            .await
            .map_err(|e| anyhow!("cannot declare queryable on {key}: {e}"))?;
        Ok(Self { rx: tokio::sync::Mutex::new(rx), key, _inner: inner })
    }

    /// The next query; `None` once the session is closed.
    pub async fn recv(&self) -> Option<Query> {
        self.rx.lock().await.recv().await
    }

    /// The key served.
    pub fn key(&self) -> &str {
        &self.key
    }
}

/// Asks `selector` and decodes the first answer as `M`: `Ok(Err(text))` when the
/// service answered with an error, `Err` when nothing answered within `timeout` or the
/// answer was not a valid `M`.
pub async fn get<M: Message>(
    session: &Session,
    selector: &str,
    timeout: Duration,
) -> anyhow::Result<Result<M, String>> {
    let replies = session.get(selector).timeout(timeout).await.map_err(|e| anyhow!("cannot ask {selector}: {e}"))?;
    let Ok(reply) = replies.recv_async().await else {
        bail!("no answer to {selector} within {} ms", timeout.as_millis());
    };
    match reply.into_result() {
        Ok(sample) => {
            let bytes = sample.payload().to_bytes();
            let (_, body) = schemas::decode::<M>(&bytes).with_context(|| format!("answer to {selector}"))?;
            Ok(Ok(body))
        }
        Err(e) => Ok(Err(String::from_utf8_lossy(&e.payload().to_bytes()).into_owned())),
    }
}

/// `%xx` escapes decoded (a `+` stays a `+`); a malformed escape is kept as it is.
fn percent_decoded(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match (b[i], b.get(i + 1).copied().and_then(hex), b.get(i + 2).copied().and_then(hex)) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::percent_decoded;

    #[test]
    fn escapes_are_decoded_and_broken_ones_kept() {
        assert_eq!(percent_decoded("room%20204"), "room 204");
        assert_eq!(percent_decoded("caf%C3%A9"), "café");
        assert_eq!(percent_decoded("100%"), "100%");
        assert_eq!(percent_decoded("a%zz"), "a%zz");
        assert_eq!(percent_decoded("room 204"), "room 204");
    }
}
