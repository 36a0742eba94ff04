//! HTTPS for the phone: phone browsers give a page motion sensors, speech input and
//! vibration only in a secure context. A certificate the user gives, or one made on
//! first run (self-signed, for the names and addresses the phone will use) and kept.

use std::fs;
use std::net::{IpAddr, SocketAddr};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, Context};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use tokio::net::TcpListener;
use tokio::sync::mpsc;
use tokio_rustls::server::TlsStream;
use tokio_rustls::TlsAcceptor;

/// A handshake that takes longer than this is dropped (a stalled client must not
/// hold a connection slot).
pub const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(10);

/// Where the certificate and key are.
#[derive(Debug, Clone, PartialEq)]
pub struct CertFiles {
    /// PEM certificate chain.
    pub cert: PathBuf,
    /// PEM private key.
    pub key: PathBuf,
    /// Whether the bridge made them (self-signed).
    pub made: bool,
}

/// The user's certificate, or the one kept in `state_dir` (made now if missing) for
/// `localhost`, this host's name and `extra_ips`.
pub fn certificate(given: Option<(&Path, &Path)>, state_dir: &Path, extra_ips: &[IpAddr]) -> anyhow::Result<CertFiles> {
    if let Some((cert, key)) = given {
        return Ok(CertFiles { cert: cert.to_path_buf(), key: key.to_path_buf(), made: false });
    }
    let cert = state_dir.join("phone-bridge.crt");
    let key = state_dir.join("phone-bridge.key");
    if cert.exists() && key.exists() {
        return Ok(CertFiles { cert, key, made: false });
    }
    let mut names = vec!["localhost".to_string()];
    if let Ok(host) = fs::read_to_string("/etc/hostname") {
        let host = host.trim();
        if !host.is_empty() {
            names.push(host.to_string());
            names.push(format!("{host}.local"));
        }
    }
    let mut params = rcgen::CertificateParams::new(names).context("certificate names")?;
    params.subject_alt_names.push(rcgen::SanType::IpAddress(IpAddr::from([127, 0, 0, 1])));
    for ip in extra_ips {
        params.subject_alt_names.push(rcgen::SanType::IpAddress(*ip));
    }
    params.distinguished_name.push(rcgen::DnType::CommonName, "wearnav phone bridge");
    let key_pair = rcgen::KeyPair::generate().context("making a key")?;
    let made = params.self_signed(&key_pair).context("making a self-signed certificate")?;
    fs::create_dir_all(state_dir).with_context(|| format!("cannot make {}", state_dir.display()))?;
    write_private(&key, key_pair.serialize_pem().as_bytes())?;
    fs::write(&cert, made.pem()).with_context(|| format!("cannot write {}", cert.display()))?;
    Ok(CertFiles { cert, key, made: true })
}

fn write_private(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    use std::io::Write;
    let mut options = fs::OpenOptions::new();
    options.write(true).create(true).truncate(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    let mut f = options.open(path).with_context(|| format!("cannot write {}", path.display()))?;
    f.write_all(bytes)?;
    Ok(())
}

/// A rustls server configuration from PEM files.
pub fn server_config(files: &CertFiles) -> anyhow::Result<rustls::ServerConfig> {
    let certs: Vec<CertificateDer<'static>> = CertificateDer::pem_file_iter(&files.cert)
        .with_context(|| format!("cannot read the certificate {}", files.cert.display()))?
        .collect::<Result<_, _>>()
        .with_context(|| format!("{} is not a PEM certificate chain", files.cert.display()))?;
    if certs.is_empty() {
        return Err(anyhow!("{} holds no certificate", files.cert.display()));
    }
    let key = PrivateKeyDer::from_pem_file(&files.key)
        .with_context(|| format!("cannot read a PEM private key from {}", files.key.display()))?;
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let mut config = rustls::ServerConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .context("TLS versions")?
        .with_no_client_auth()
        .with_single_cert(certs, key)
        .context("the certificate and key do not go together")?;
    config.alpn_protocols = vec![b"http/1.1".to_vec()];
    Ok(config)
}

/// A listener whose connections are TLS already: handshakes run side by side (a slow
/// one holds no other up) and failed ones are logged and dropped.
pub struct TlsListener {
    local: SocketAddr,
    ready: mpsc::Receiver<(TlsStream<tokio::net::TcpStream>, SocketAddr)>,
    _accepting: tokio::task::JoinHandle<()>,
}

impl TlsListener {
    /// Serve TLS with `config` on `listener`.
    pub fn new(listener: TcpListener, config: rustls::ServerConfig) -> std::io::Result<Self> {
        let local = listener.local_addr()?;
        let acceptor = TlsAcceptor::from(Arc::new(config));
        let (tx, ready) = mpsc::channel(16);
        let accepting = tokio::spawn(async move {
            loop {
                let (tcp, peer) = match listener.accept().await {
                    Ok(c) => c,
                    Err(e) => {
                        tracing::warn!("phone page: accept failed: {e}");
                        tokio::time::sleep(Duration::from_millis(100)).await;
                        continue;
                    }
                };
                let (acceptor, tx) = (acceptor.clone(), tx.clone());
                tokio::spawn(async move {
                    match tokio::time::timeout(HANDSHAKE_TIMEOUT, acceptor.accept(tcp)).await {
                        Ok(Ok(tls)) => {
                            let _ = tx.send((tls, peer)).await;
                        }
                        Ok(Err(e)) => tracing::info!("TLS handshake with {peer} failed: {e}"),
                        Err(_) => tracing::info!("TLS handshake with {peer} timed out"),
                    }
                });
            }
        });
        Ok(Self { local, ready, _accepting: accepting })
    }
}

impl Drop for TlsListener {
    fn drop(&mut self) {
        self._accepting.abort();
    }
}

impl axum::serve::Listener for TlsListener {
    type Io = TlsStream<tokio::net::TcpStream>;
    type Addr = SocketAddr;

    async fn accept(&mut self) -> (Self::Io, Self::Addr) {
        match self.ready.recv().await {
            Some(c) => c,
            // the accepting task only ends when dropped with us
            None => std::future::pending().await,
        }
    }

    fn local_addr(&self) -> std::io::Result<Self::Addr> {
        Ok(self.local)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_certificate_is_made_once_kept_and_loads() {
        let scratch = tempfile::Builder::new().prefix("wearnav-tls-").tempdir().unwrap();
        let dir = scratch.path();
        let made = certificate(None, dir, &[IpAddr::from([192, 168, 1, 20])]).unwrap();
        assert!(made.made);
        let pem = fs::read_to_string(&made.cert).unwrap();
        assert!(pem.starts_with("-----BEGIN CERTIFICATE-----"), "{pem}");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(fs::metadata(&made.key).unwrap().permissions().mode() & 0o777, 0o600);
        }
        let kept = certificate(None, dir, &[]).unwrap();
        assert!(!kept.made);
        assert_eq!(fs::read_to_string(&kept.cert).unwrap(), pem, "the same certificate, not a new one");
        server_config(&kept).unwrap();
        // a key that does not match is refused with a clear message
        let other = dir.join("other");
        let wrong = certificate(None, &other, &[]).unwrap();
        let mixed = CertFiles { cert: kept.cert.clone(), key: wrong.key.clone(), made: false };
        let e = format!("{:#}", server_config(&mixed).unwrap_err());
        assert!(e.contains("do not go together"), "{e}");
    }
}
