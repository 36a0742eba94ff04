//! `wearnav up`: one command per machine. A placement manifest (deploy/hosts/) says which
//! agents run on which host, with which arguments and Zenoh configuration; `up` starts
//! this host's, prefixes their output with their names, and restarts one that dies
//! (waiting 0.5 s, then twice as long each time it dies again soon after, up to 30 s).
//! Ctrl-C or SIGTERM stops them all (SIGTERM, then SIGKILL after 5 s).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::Duration;

use anyhow::{bail, Context};
use clap::Args;
use serde::Deserialize;
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::{Child, Command};
use tokio::sync::watch;
use tokio::time::Instant;

/// Start this host's agents from a placement manifest and keep them running.
#[derive(Debug, Args)]
pub struct UpArgs {
    /// Placement manifest (TOML, see deploy/hosts/README.md).
    #[arg(long, value_name = "FILE")]
    pub manifest: PathBuf,
    /// Which of the manifest's hosts this machine is.
    #[arg(long)]
    pub host: String,
    /// Directory of the agents' binaries (default: the one `wearnav` is in, then PATH).
    #[arg(long, value_name = "DIR")]
    pub bin_dir: Option<PathBuf>,
}

/// A placement manifest.
#[derive(Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Whose agents these are (`--user` for every agent).
    pub user: String,
    /// Hosts by name.
    pub hosts: BTreeMap<String, Host>,
}

/// One machine's agents.
#[derive(Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Host {
    /// What runs there, started in this order.
    #[serde(rename = "agent")]
    pub agents: Vec<AgentSpec>,
}

/// One process.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AgentSpec {
    /// Name in the log and in `up`'s reports (unique on the host).
    pub name: String,
    /// Program: `sensor-agent`, `compute-agent`, `feedback-agent`, `phone-bridge` (given
    /// `--user`), or `wearnav` (its subcommand in `args`, e.g. `router`; no `--user`).
    pub program: String,
    /// Arguments after `--user U` and `--zenoh-config FILE`.
    #[serde(default)]
    pub args: Vec<String>,
    /// Zenoh configuration (relative to the manifest's directory).
    pub zenoh_config: Option<PathBuf>,
}

const AGENTS: [&str; 4] = ["sensor-agent", "compute-agent", "feedback-agent", "phone-bridge"];
/// First wait before a restart.
const FIRST_BACKOFF: Duration = Duration::from_millis(500);
/// Longest wait before a restart.
const MAX_BACKOFF: Duration = Duration::from_secs(30);
/// Up this long, a process that dies is restarted after [`FIRST_BACKOFF`] again.
const STABLE_AFTER: Duration = Duration::from_secs(60);
/// Grace between SIGTERM and SIGKILL when stopping.
const STOP_GRACE: Duration = Duration::from_secs(5);

impl Manifest {
    /// Parses and checks a manifest: the text, a host's agents named once each, known
    /// programs.
    pub fn parse(text: &str, origin: &str) -> anyhow::Result<Self> {
        let m: Manifest = toml::from_str(text).map_err(|e| anyhow::anyhow!("{origin}: {}", e.to_string().trim()))?;
        if m.user.is_empty() {
            bail!("{origin}: `user` is empty");
        }
        for (host, h) in &m.hosts {
            if h.agents.is_empty() {
                bail!("{origin}: host `{host}` runs nothing");
            }
            for (i, a) in h.agents.iter().enumerate() {
                if h.agents[..i].iter().any(|b| b.name == a.name) {
                    bail!("{origin}: host `{host}` names `{}` twice", a.name);
                }
                if !AGENTS.contains(&a.program.as_str()) && a.program != "wearnav" {
                    bail!(
                        "{origin}: host `{host}`, agent `{}`: unknown program `{}` (one of {}, wearnav)",
                        a.name,
                        a.program,
                        AGENTS.join(", ")
                    );
                }
            }
        }
        Ok(m)
    }

    /// The agents of `host`, or which hosts there are.
    pub fn host(&self, host: &str) -> anyhow::Result<&Host> {
        self.hosts.get(host).with_context(|| {
            format!(
                "no host `{host}` in the manifest; it has {}",
                self.hosts.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        })
    }
}

/// The command line of `spec` for `user`, paths relative to `base`.
pub fn command_line(spec: &AgentSpec, user: &str, base: &Path) -> Vec<String> {
    let mut args = Vec::new();
    if spec.program != "wearnav" {
        args.extend(["--user".to_string(), user.to_string()]);
        if let Some(c) = &spec.zenoh_config {
            args.extend(["--zenoh-config".to_string(), base.join(c).display().to_string()]);
        }
    }
    args.extend(spec.args.iter().cloned());
    args
}

fn program_path(program: &str, bin_dir: Option<&Path>) -> PathBuf {
    let dir = bin_dir.map(Path::to_path_buf).or_else(|| std::env::current_exe().ok()?.parent().map(Path::to_path_buf));
    match dir.map(|d| d.join(program)).filter(|p| p.is_file()) {
        Some(p) => p,
        None => PathBuf::from(program), // from PATH
    }
}

/// The wait before the next restart, given the last one and how long the process ran.
pub fn next_backoff(last: Duration, ran: Duration) -> Duration {
    if ran >= STABLE_AFTER {
        FIRST_BACKOFF
    } else {
        (last * 2).clamp(FIRST_BACKOFF, MAX_BACKOFF)
    }
}

pub async fn run(args: &UpArgs) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&args.manifest)
        .with_context(|| format!("cannot read the manifest {}", args.manifest.display()))?;
    let manifest = Manifest::parse(&text, &args.manifest.display().to_string())?;
    let host = manifest.host(&args.host)?;
    let base = args.manifest.parent().map(Path::to_path_buf).unwrap_or_default();
    let (stop_tx, stop_rx) = watch::channel(false);
    let mut tasks = Vec::new();
    for spec in &host.agents {
        let program = program_path(&spec.program, args.bin_dir.as_deref());
        let argv = command_line(spec, &manifest.user, &base);
        println!("[up] {}: {} {}", spec.name, program.display(), argv.join(" "));
        tasks.push(tokio::spawn(supervise(spec.name.clone(), program, argv, stop_rx.clone())));
    }
    let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())?;
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        _ = term.recv() => {}
    }
    println!("[up] stopping {} agents", tasks.len());
    let _ = stop_tx.send(true);
    for t in tasks {
        let _ = t.await;
    }
    Ok(())
}

/// Keeps one process running until `stop`.
async fn supervise(name: String, program: PathBuf, argv: Vec<String>, mut stop: watch::Receiver<bool>) {
    let mut backoff = Duration::ZERO;
    loop {
        let started = Instant::now();
        let mut child = match spawn(&name, &program, &argv) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("[up] {name}: cannot start {}: {e:#}", program.display());
                backoff = next_backoff(backoff, Duration::ZERO);
                if wait_or_stop(&mut stop, backoff).await {
                    return;
                }
                continue;
            }
        };
        println!("[up] {name}: started (pid {})", child.id().unwrap_or(0));
        tokio::select! {
            status = child.wait() => {
                let ran = started.elapsed();
                backoff = next_backoff(backoff, ran);
                let how = status.map_or_else(|e| format!("could not be waited for ({e})"), describe);
                println!("[up] {name}: {how} after {:.1} s; restarting in {:.1} s", ran.as_secs_f64(), backoff.as_secs_f64());
                if wait_or_stop(&mut stop, backoff).await {
                    return;
                }
            }
            _ = stop.changed() => {
                terminate(&name, &mut child).await;
                return;
            }
        }
    }
}

fn describe(status: std::process::ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(code), _) => format!("exited with code {code}"),
        (None, Some(sig)) => format!("killed by signal {sig}"),
        _ => "ended".to_string(),
    }
}

/// Sleeps `d`; true if asked to stop meanwhile.
async fn wait_or_stop(stop: &mut watch::Receiver<bool>, d: Duration) -> bool {
    if *stop.borrow() {
        return true;
    }
    tokio::select! {
        _ = tokio::time::sleep(d) => *stop.borrow(),
        _ = stop.changed() => true,
    }
}

fn spawn(name: &str, program: &Path, argv: &[String]) -> anyhow::Result<Child> {
    let mut child = Command::new(program)
        .args(argv)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true)
        .spawn()?;
    if let Some(out) = child.stdout.take() {
        tokio::spawn(forward(name.to_string(), out, false));
    }
    if let Some(err) = child.stderr.take() {
        tokio::spawn(forward(name.to_string(), err, true));
    }
    Ok(child)
}

/// Copies a child's output line by line, each line prefixed with its name.
async fn forward(name: String, from: impl tokio::io::AsyncRead + Unpin, to_stderr: bool) {
    let mut lines = BufReader::new(from).lines();
    while let Ok(Some(line)) = lines.next_line().await {
        if to_stderr {
            eprintln!("[{name}] {line}");
        } else {
            println!("[{name}] {line}");
        }
    }
}

/// SIGTERM, then SIGKILL after [`STOP_GRACE`].
async fn terminate(name: &str, child: &mut Child) {
    if let Some(pid) = child.id() {
        // SAFETY: kill(2) on our own child's pid; no memory is touched.
        unsafe {
            libc::kill(pid as libc::pid_t, libc::SIGTERM);
        }
    }
    match tokio::time::timeout(STOP_GRACE, child.wait()).await {
        Ok(_) => println!("[up] {name}: stopped"),
        Err(_) => {
            let _ = child.kill().await;
            println!("[up] {name}: killed after {} s", STOP_GRACE.as_secs());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MANIFEST: &str = r#"
user = "alice"
hosts.backpack.agent = [
  { name = "router", program = "wearnav", args = ["router", "--zenoh-config", "/keys/router.json5"] },
  { name = "compute", program = "compute-agent", zenoh_config = "keys/compute.json5", args = ["--map", "maps/building"] },
]
hosts.cane.agent = [{ name = "camera", program = "sensor-agent", args = ["--source", "openni2"] }]
"#;

    #[test]
    fn a_manifest_gives_each_host_its_command_lines() {
        let m = Manifest::parse(MANIFEST, "site.toml").unwrap();
        let backpack = m.host("backpack").unwrap();
        assert_eq!(backpack.agents.len(), 2);
        assert_eq!(
            command_line(&backpack.agents[1], &m.user, Path::new("/etc/wearnav")),
            ["--user", "alice", "--zenoh-config", "/etc/wearnav/keys/compute.json5", "--map", "maps/building"]
        );
        assert_eq!(
            command_line(&backpack.agents[0], &m.user, Path::new("/etc/wearnav")),
            ["router", "--zenoh-config", "/keys/router.json5"]
        );
        let e = m.host("phone").unwrap_err().to_string();
        assert!(e.contains("no host `phone`") && e.contains("backpack, cane"), "{e}");
    }

    #[test]
    fn bad_manifests_are_refused_with_the_reason() {
        let twice = MANIFEST.replace("name = \"router\"", "name = \"compute\"");
        assert!(Manifest::parse(&twice, "m").unwrap_err().to_string().contains("names `compute` twice"));
        let unknown = MANIFEST.replace("program = \"sensor-agent\"", "program = \"rm\"");
        assert!(Manifest::parse(&unknown, "m").unwrap_err().to_string().contains("unknown program `rm`"));
        let typo = MANIFEST.replace("zenoh_config =", "zenoh_cfg =");
        assert!(Manifest::parse(&typo, "m").unwrap_err().to_string().contains("zenoh_cfg"));
    }

    #[test]
    fn restarts_back_off_while_a_process_keeps_dying_and_not_after_it_ran_a_while() {
        let mut b = Duration::ZERO;
        let mut waits = Vec::new();
        for _ in 0..9 {
            b = next_backoff(b, Duration::from_secs(1));
            waits.push(b.as_millis());
        }
        assert_eq!(waits, [500, 1000, 2000, 4000, 8000, 16000, 30000, 30000, 30000]);
        assert_eq!(next_backoff(Duration::from_secs(30), Duration::from_secs(61)), FIRST_BACKOFF);
    }
}
