//! Cooperative shutdown shared by every task of an agent (Ctrl-C, demo end, tests).

use tokio::sync::watch;

/// A clonable shutdown signal: `trigger` once, every `triggered().await` returns.
#[derive(Debug, Clone)]
pub struct Shutdown {
    tx: std::sync::Arc<watch::Sender<bool>>,
    rx: watch::Receiver<bool>,
}

impl Default for Shutdown {
    fn default() -> Self {
        Self::new()
    }
}

impl Shutdown {
    /// A fresh, untriggered signal.
    pub fn new() -> Self {
        let (tx, rx) = watch::channel(false);
        Self { tx: std::sync::Arc::new(tx), rx }
    }

    /// Ask everything holding a clone to stop.
    pub fn trigger(&self) {
        self.tx.send_replace(true);
    }

    /// [`Self::trigger`] as the process ends (a signal, the demo's end): its sessions
    /// are closing from here ([`crate::logging::closing`]).
    pub fn trigger_exit(&self) {
        crate::logging::closing();
        self.trigger();
    }

    /// True once triggered.
    pub fn is_triggered(&self) -> bool {
        *self.rx.borrow()
    }

    /// Resolves when triggered (at once if it already was).
    pub async fn triggered(&self) {
        let mut rx = self.rx.clone();
        // An error means every sender is gone, which can only happen once we are dropped.
        let _ = rx.wait_for(|v| *v).await;
    }

    /// [`Self::trigger_exit`] on Ctrl-C or SIGTERM (spawned task; returns at once).
    pub fn trigger_on_signals(&self) {
        let this = self.clone();
        tokio::spawn(async move {
            let ctrl_c = tokio::signal::ctrl_c();
            #[cfg(unix)]
            {
                let mut term = match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
                    Ok(s) => s,
                    Err(e) => {
                        tracing::warn!("cannot listen for SIGTERM: {e}");
                        let _ = ctrl_c.await;
                        this.trigger_exit();
                        return;
                    }
                };
                tokio::select! {
                    _ = ctrl_c => {}
                    _ = term.recv() => {}
                }
            }
            #[cfg(not(unix))]
            let _ = ctrl_c.await;
            tracing::info!("shutdown requested");
            this.trigger_exit();
        });
    }
}
