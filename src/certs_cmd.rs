//! `wearnav certs`: the secure profile's keys (deploy/secure/README.md). A small
//! certificate authority, a certificate per agent and monitor (its common name is the
//! role the router's access-control list knows it by), one for the router (its names
//! and addresses, which the clients check), and the Zenoh configurations that use them,
//! written from the templates in `deploy/secure/` with this directory's absolute paths.

use std::fs;
use std::net::IpAddr;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use clap::Args;
use rcgen::{
    BasicConstraints, CertificateParams, DistinguishedName, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose, SanType,
};

/// Roles the router's access-control list grants (deploy/secure/router.json5).
pub const ROLES: [&str; 6] = ["sensor", "compute", "feedback", "phone-bridge", "tool", "monitor"];

/// The router's configuration template and the clients'.
const ROUTER_TEMPLATE: &str = include_str!("../deploy/secure/router.json5");
const CLIENT_TEMPLATE: &str = include_str!("../deploy/secure/client.json5");

/// Make the secure profile's certificate authority, certificates and Zenoh
/// configurations: `DIR/ca.pem` (the authority every node trusts), `DIR/<name>.pem` and
/// `DIR/<name>.key` for the router and each client, `DIR/router.json5` and
/// `DIR/<name>.json5` to pass as `--zenoh-config`. An existing authority in DIR is kept
/// and signs the new certificates (add a laptop's monitor later with
/// `--clients laptop:monitor`).
#[derive(Debug, Args)]
pub struct CertsArgs {
    /// Directory to write to (made if missing). Keep it private: it holds every key.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// The router's endpoint as clients reach it, e.g. `tls/192.168.1.20:7447` or
    /// `tls/backpack.local:7447`; its host goes into the router's certificate.
    #[arg(long, value_name = "ENDPOINT", default_value = "tls/127.0.0.1:7447")]
    pub router: String,
    /// More names or addresses for the router's certificate (comma-separated).
    #[arg(long, value_delimiter = ',', value_name = "HOST")]
    pub router_names: Vec<String>,
    /// Clients as `name:role` (comma-separated; `name` alone for a name that is a
    /// role). Roles: sensor, compute, feedback, phone-bridge, tool (commands, e.g.
    /// schemas/python/send.py), monitor (subscribes only).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "NAME[:ROLE]",
        default_value = "sensor,compute,feedback,phone-bridge,tool,monitor"
    )]
    pub clients: Vec<String>,
    /// Days the certificates are valid.
    #[arg(long, default_value_t = 825)]
    pub days: u32,
    /// Replace certificates (and the authority) that exist already.
    #[arg(long)]
    pub force: bool,
}

/// One client to make a certificate for.
#[derive(Debug, Clone, PartialEq)]
pub struct Client {
    /// File name and certificate common name.
    pub name: String,
    /// Access-control role: the certificate's common name.
    pub role: String,
}

/// `name:role` or `name`; names are file names: letters, digits, `-` and `_`.
pub fn parse_client(text: &str) -> anyhow::Result<Client> {
    let (name, role) = text.split_once(':').unwrap_or((text, text));
    let ok = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if !ok(name) {
        bail!("client `{text}`: a name is letters, digits, - and _ (it names the files)");
    }
    if !ROLES.contains(&role) {
        bail!("client `{text}`: unknown role `{role}`; roles are {}", ROLES.join(", "));
    }
    Ok(Client { name: name.to_string(), role: role.to_string() })
}

/// The host of a `tls/HOST:PORT` endpoint.
fn endpoint_host(endpoint: &str) -> anyhow::Result<String> {
    let rest = endpoint
        .strip_prefix("tls/")
        .with_context(|| format!("--router {endpoint}: the secure profile connects over TLS: `tls/HOST:PORT`"))?;
    let (host, port) = rest.rsplit_once(':').with_context(|| format!("--router {endpoint}: no port"))?;
    port.parse::<u16>().with_context(|| format!("--router {endpoint}: `{port}` is no port"))?;
    Ok(host.trim_start_matches('[').trim_end_matches(']').to_string())
}

fn san(host: &str) -> anyhow::Result<SanType> {
    Ok(match host.parse::<IpAddr>() {
        Ok(ip) => SanType::IpAddress(ip),
        Err(_) => SanType::DnsName(host.to_string().try_into().with_context(|| format!("`{host}` is no host name"))?),
    })
}

fn validity(params: &mut CertificateParams, days: u32) {
    let now = time::OffsetDateTime::now_utc();
    params.not_before = now - time::Duration::hours(1);
    params.not_after = now + time::Duration::days(i64::from(days));
}

/// The authority's parameters: the same every time, so a kept key signs as before.
fn ca_params(days: u32) -> CertificateParams {
    let mut params = CertificateParams::default();
    params.distinguished_name = DistinguishedName::new();
    params.distinguished_name.push(DnType::CommonName, "wearnav deployment CA");
    params.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign, KeyUsagePurpose::DigitalSignature];
    validity(&mut params, days);
    params
}

fn write_private(path: &Path, text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut options = fs::OpenOptions::new();
    options.write(true).create(true).truncate(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    let mut f = options.open(path).with_context(|| format!("cannot write {}", path.display()))?;
    f.write_all(text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))
}

fn write(path: &Path, text: &str) -> anyhow::Result<()> {
    fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

/// A template with `${DIR}`, `${NAME}`, `${ROUTER}` (the endpoint) and `${PORT}` (its
/// port) filled in.
fn fill(template: &str, dir: &Path, name: &str, router: &str) -> String {
    let port = router.rsplit_once(':').map_or("7447", |(_, p)| p);
    template
        .replace("${DIR}", &dir.display().to_string())
        .replace("${NAME}", name)
        .replace("${ROUTER}", router)
        .replace("${PORT}", port)
}

/// What `certs` wrote, for its report and tests.
#[derive(Debug, Default)]
pub struct Written {
    /// Files written, in order.
    pub files: Vec<PathBuf>,
    /// Whether the authority was made now (else an existing one signed).
    pub new_ca: bool,
}

/// Writes everything `args` asks for.
pub fn make(args: &CertsArgs) -> anyhow::Result<Written> {
    let clients = args.clients.iter().map(|c| parse_client(c)).collect::<anyhow::Result<Vec<_>>>()?;
    if clients.iter().any(|c| c.name == "router" || c.name == "ca") {
        bail!("`router` and `ca` name the router's and the authority's files; choose another client name");
    }
    let router_host = endpoint_host(&args.router)?;
    if args.days == 0 {
        bail!("--days must be at least 1");
    }
    fs::create_dir_all(&args.out).with_context(|| format!("cannot make {}", args.out.display()))?;
    let dir = fs::canonicalize(&args.out).with_context(|| format!("cannot resolve {}", args.out.display()))?;
    let mut written = Written::default();

    let (ca_pem, ca_key_path) = (dir.join("ca.pem"), dir.join("ca.key"));
    let ca_key = if ca_key_path.exists() && ca_pem.exists() && !args.force {
        let text =
            fs::read_to_string(&ca_key_path).with_context(|| format!("cannot read {}", ca_key_path.display()))?;
        KeyPair::from_pem(&text).with_context(|| format!("{} is not a PEM private key", ca_key_path.display()))?
    } else {
        let key = KeyPair::generate().context("making the authority's key")?;
        let cert = ca_params(args.days).self_signed(&key).context("making the authority's certificate")?;
        write_private(&ca_key_path, &key.serialize_pem())?;
        write(&ca_pem, &cert.pem())?;
        written.files.extend([ca_key_path.clone(), ca_pem.clone()]);
        written.new_ca = true;
        key
    };
    let issuer = Issuer::new(ca_params(args.days), ca_key);

    let fresh_ca = written.new_ca;
    let issue = |name: &str, common_name: &str, sans: Vec<SanType>, server: bool| -> anyhow::Result<[PathBuf; 2]> {
        let (cert_path, key_path) = (dir.join(format!("{name}.pem")), dir.join(format!("{name}.key")));
        if cert_path.exists() && !args.force && !fresh_ca {
            bail!("{} exists; --force replaces it", cert_path.display());
        }
        let mut params = CertificateParams::default();
        params.distinguished_name = DistinguishedName::new();
        params.distinguished_name.push(DnType::CommonName, common_name);
        params.subject_alt_names = sans;
        params.key_usages = vec![KeyUsagePurpose::DigitalSignature, KeyUsagePurpose::KeyEncipherment];
        params.extended_key_usages = if server {
            vec![ExtendedKeyUsagePurpose::ServerAuth, ExtendedKeyUsagePurpose::ClientAuth]
        } else {
            vec![ExtendedKeyUsagePurpose::ClientAuth]
        };
        validity(&mut params, args.days);
        let key = KeyPair::generate().with_context(|| format!("making {name}'s key"))?;
        let cert = params.signed_by(&key, &issuer).with_context(|| format!("signing {name}'s certificate"))?;
        write_private(&key_path, &key.serialize_pem())?;
        write(&cert_path, &cert.pem())?;
        Ok([key_path, cert_path])
    };

    let mut router_sans = vec![san("localhost")?, SanType::IpAddress(IpAddr::from([127, 0, 0, 1])), san(&router_host)?];
    for host in &args.router_names {
        router_sans.push(san(host.trim())?);
    }
    router_sans.dedup();
    // the router's own certificate and configuration are kept when the authority is
    // (a client added later needs no new router)
    if fresh_ca || args.force || !dir.join("router.pem").exists() {
        written.files.extend(issue("router", "router", router_sans, true)?);
        let router_conf = dir.join("router.json5");
        write(&router_conf, &fill(ROUTER_TEMPLATE, &dir, "router", &args.router))?;
        written.files.push(router_conf);
    }
    for client in &clients {
        // the common name is what the router's list matches: the role
        written.files.extend(issue(&client.name, &client.role, vec![], false)?);
        let conf = dir.join(format!("{}.json5", client.name));
        write(&conf, &fill(CLIENT_TEMPLATE, &dir, &client.name, &args.router))?;
        written.files.push(conf);
    }
    Ok(written)
}

pub fn run(args: &CertsArgs) -> anyhow::Result<()> {
    let written = make(args)?;
    if !written.new_ca {
        println!("kept the authority in {} (ca.pem, ca.key)", args.out.display());
    }
    for f in &written.files {
        println!("wrote {}", f.display());
    }
    println!(
        "next: on the router's host `wearnav router --zenoh-config {0}/router.json5`; each agent with \
         `--zenoh-config {0}/<its name>.json5` (deploy/secure/README.md). Copy to each host only the files it needs: \
         ca.pem and its own .pem, .key and .json5.",
        args.out.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(out: &Path, clients: &[&str]) -> CertsArgs {
        CertsArgs {
            out: out.to_path_buf(),
            router: "tls/127.0.0.1:7447".into(),
            router_names: vec!["backpack.local".into()],
            clients: clients.iter().map(|c| c.to_string()).collect(),
            days: 30,
            force: false,
        }
    }

    #[test]
    fn clients_are_names_with_known_roles() {
        assert_eq!(parse_client("laptop:monitor").unwrap(), Client { name: "laptop".into(), role: "monitor".into() });
        assert_eq!(parse_client("compute").unwrap().role, "compute");
        let e = parse_client("x:admin").unwrap_err().to_string();
        assert!(e.contains("unknown role `admin`") && e.contains("phone-bridge"), "{e}");
        assert!(parse_client("my laptop:monitor").unwrap_err().to_string().contains("names the files"));
        assert!(parse_client("").is_err());
    }

    #[test]
    fn the_router_is_reached_over_tls_at_a_port() {
        assert_eq!(endpoint_host("tls/192.168.1.20:7447").unwrap(), "192.168.1.20");
        assert_eq!(endpoint_host("tls/[::1]:7447").unwrap(), "::1");
        assert!(endpoint_host("tcp/192.168.1.20:7447").unwrap_err().to_string().contains("over TLS"));
        assert!(endpoint_host("tls/backpack").unwrap_err().to_string().contains("no port"));
        assert!(endpoint_host("tls/backpack:http").unwrap_err().to_string().contains("no port"));
    }

    #[test]
    fn a_kept_authority_signs_a_client_added_later_and_nothing_is_overwritten_unasked() {
        let scratch = tempfile::Builder::new().prefix("wearnav-certs-").tempdir().unwrap();
        let dir = scratch.path();
        let first = make(&args(dir, &["compute", "monitor"])).unwrap();
        assert!(first.new_ca);
        let ca = fs::read_to_string(dir.join("ca.pem")).unwrap();
        let router_conf = fs::read_to_string(dir.join("router.json5")).unwrap();
        let canonical = fs::canonicalize(dir).unwrap();
        assert!(router_conf.contains(&format!("\"{}/router.key\"", canonical.display())), "paths filled in");
        assert!(router_conf.contains("tls/0.0.0.0:7447") && !router_conf.contains("${"), "{router_conf}");
        let client = fs::read_to_string(dir.join("monitor.json5")).unwrap();
        assert!(
            client.contains("\"tls/127.0.0.1:7447\"") && client.contains("/monitor.key\"") && !client.contains("${")
        );
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = fs::metadata(dir.join("ca.key")).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o600, "keys are private");
        }
        // the same clients again: refused, nothing replaced
        let again = make(&args(dir, &["monitor"])).unwrap_err().to_string();
        assert!(again.contains("monitor.pem exists") && again.contains("--force"), "{again}");
        // a laptop added: the authority and the router kept
        let later = make(&args(dir, &["laptop:monitor"])).unwrap();
        assert!(!later.new_ca);
        let names: Vec<_> = later.files.iter().map(|f| f.file_name().unwrap().to_string_lossy().into_owned()).collect();
        assert_eq!(names, ["laptop.key", "laptop.pem", "laptop.json5"]);
        assert_eq!(fs::read_to_string(dir.join("ca.pem")).unwrap(), ca);
    }
}
