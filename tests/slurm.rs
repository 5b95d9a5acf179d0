//! `scripts/slurm_brdf.sh` end to end on a real single-node Slurm: Debian's
//! `slurm-wlm` (22.05) and `munge`, started by this test as root in a
//! private folder (its own munge socket and key, `slurm.conf`, ports, state,
//! spool, logs and pid files) and stopped by pid when the test ends, passed
//! or not (a `Drop` guard).
//!
//! * Bad input is refused before anything is submitted: exit status 2, one
//!   line on stderr, an empty queue and no shard folder.
//! * A clean run (the default 8 shards: options without SHARDS) merges into
//!   `brdf.csv` and `inplane.csv` byte-identical to one local `roks brdf`
//!   run, and `summary.json` equal except for its timings.
//! * A run of 4 shards with shard 1's roks killed (`kill -9`) mid-run and
//!   the still pending shard 3 cancelled (`scancel`): Slurm cancels the merge
//!   (it does not pend forever), `status` lists shard 001 as failed and 003
//!   as missing and prints the command resubmitting exactly those two;
//!   running that command gives the single run's bytes again.
//! * An object scene (`scenes/baffled-tube-10.toml`) in 3 shards: the
//!   script runs `roks trace`, refuses more shards than batches, and the
//!   merge gives the single run's `reflectance.csv`, `farfield.csv` and
//!   picture byte for byte (`summary.json` but timings).
//!
//! Skipped with a message when the Slurm and munge commands are missing or
//! the test is not root, unless `ROKS_REQUIRE_SLURM=1` (set by `.ci/run`
//! after installing them), which turns that into a failure.

mod cli_common;

use std::fs;
use std::io::Read as _;
use std::net::TcpListener;
use std::os::unix::fs::PermissionsExt as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use cli_common::{read, summary_without_timing};
use rustix::process::{Pid, Signal, kill_process};

/// The commands the test needs.
const COMMANDS: [&str; 7] = [
    "munged",
    "slurmctld",
    "slurmd",
    "sbatch",
    "squeue",
    "scancel",
    "sinfo",
];

/// Photons per incidence angle of the runs: 8 batches of 4096.
const PHOTONS: &str = "32768";

/// Photons of the object scene's one beam position: 3 batches of 4096.
const TUBE_PHOTONS: &str = "12288";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn on_path(cmd: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(cmd).is_file()))
}

/// Whether Slurm can be started here; says why not (or fails, when
/// `ROKS_REQUIRE_SLURM=1`).
fn slurm_available() -> bool {
    let missing: Vec<&str> = COMMANDS.into_iter().filter(|c| !on_path(c)).collect();
    let why = if !missing.is_empty() {
        format!(
            "no {} (Debian: apt-get install slurm-wlm munge)",
            missing.join(", ")
        )
    } else if !rustix::process::geteuid().is_root() {
        "not root (slurmd and munged are started by this test)".to_string()
    } else {
        return true;
    };
    let required = std::env::var("ROKS_REQUIRE_SLURM").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "ROKS_REQUIRE_SLURM=1 but Slurm cannot be started: {why}"
    );
    eprintln!("slurm: skipped: {why}");
    false
}

/// Poll `ready` every 50 ms until it holds, panicking with `what` after
/// `limit`.
fn wait_for(what: &str, limit: Duration, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(
            start.elapsed() < limit,
            "timed out after {limit:?} waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Two distinct free TCP ports (bound at once to port 0, then released).
fn free_ports() -> (u16, u16) {
    let bind = || TcpListener::bind("0.0.0.0:0").expect("bind a free port");
    let (a, b) = (bind(), bind());
    let port = |l: &TcpListener| l.local_addr().expect("a bound port").port();
    (port(&a), port(&b))
}

/// A private single-node Slurm: munged, slurmctld and slurmd as children of
/// the test, all in `dir`.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
    daemons: Vec<Child>,
}

impl Cluster {
    fn start() -> Self {
        let dir = std::env::temp_dir().join(format!("roks-slurm-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        // munged wants its socket's folders open to all and its key private.
        for (sub, mode) in [
            ("", 0o755),
            ("munge", 0o755),
            ("key", 0o700),
            ("state", 0o700),
            ("spool", 0o755),
            ("log", 0o755),
        ] {
            let d = dir.join(sub);
            fs::create_dir_all(&d).unwrap();
            fs::set_permissions(&d, fs::Permissions::from_mode(mode)).unwrap();
        }
        let key = dir.join("key/munge.key");
        let mut bytes = vec![0u8; 1024];
        fs::File::open("/dev/urandom")
            .and_then(|mut f| f.read_exact(&mut bytes))
            .expect("read /dev/urandom");
        fs::write(&key, &bytes).unwrap();
        fs::set_permissions(&key, fs::Permissions::from_mode(0o400)).unwrap();
        let socket = dir.join("munge/munge.socket");
        let conf = dir.join("slurm.conf");
        let mut cluster = Self {
            dir: dir.clone(),
            conf: conf.clone(),
            daemons: Vec::new(),
        };
        cluster.spawn(
            "munged",
            Command::new("munged").arg("-F").args([
                format!("--socket={}", socket.display()),
                format!("--key-file={}", key.display()),
                format!("--pid-file={}", dir.join("munge/munged.pid").display()),
                format!("--log-file={}", dir.join("log/munged.log").display()),
                format!("--seed-file={}", dir.join("key/munged.seed").display()),
            ]),
        );
        wait_for("munged's socket", Duration::from_secs(10), || {
            socket.exists()
        });

        // This host as slurmd sees it: NodeName, CPUs, sockets, cores, RealMemory.
        let node = Command::new("slurmd")
            .arg("-C")
            .output()
            .expect("slurmd -C");
        let node = String::from_utf8_lossy(&node.stdout);
        let node = node
            .lines()
            .next()
            .expect("slurmd -C prints the node")
            .to_owned();
        let host = node
            .split_whitespace()
            .find_map(|w| w.strip_prefix("NodeName="))
            .expect("NodeName in slurmd -C")
            .to_owned();
        let d = dir.display();
        let ports = free_ports();
        let text = format!(
            "ClusterName=rokstest\n\
             SlurmctldHost={host}(127.0.0.1)\n\
             SlurmctldPort={ctld}\n\
             SlurmdPort={slurmd}\n\
             SlurmUser=root\n\
             SlurmdUser=root\n\
             AuthType=auth/munge\n\
             CredType=cred/munge\n\
             AuthInfo=socket={socket}\n\
             StateSaveLocation={d}/state\n\
             SlurmdSpoolDir={d}/spool\n\
             SlurmctldPidFile={d}/slurmctld.pid\n\
             SlurmdPidFile={d}/slurmd.pid\n\
             SlurmctldLogFile={d}/log/slurmctld.log\n\
             SlurmdLogFile={d}/log/slurmd.log\n\
             ProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\n\
             JobAcctGatherType=jobacct_gather/none\n\
             AccountingStorageType=accounting_storage/none\n\
             JobCompType=jobcomp/none\n\
             MpiDefault=none\n\
             SelectType=select/cons_tres\n\
             SelectTypeParameters=CR_CPU\n\
             ReturnToService=2\n\
             {node} NodeAddr=127.0.0.1 State=UNKNOWN\n\
             PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
            ctld = ports.0,
            slurmd = ports.1,
            socket = socket.display(),
        );
        fs::write(&conf, text).unwrap();
        for daemon in ["slurmctld", "slurmd"] {
            cluster.spawn(daemon, Command::new(daemon).arg("-D").arg("-f").arg(&conf));
        }
        wait_for(
            "the node to be idle in sinfo",
            Duration::from_secs(60),
            || cluster.run("sinfo", &["-h", "-N", "-o", "%T"]).trim() == "idle",
        );
        cluster
    }

    /// Start a daemon in the foreground, its output in log/NAME.out.
    fn spawn(&mut self, name: &str, cmd: &mut Command) {
        let out = fs::File::create(self.dir.join(format!("log/{name}.out"))).unwrap();
        let child = cmd
            .env("SLURM_CONF", &self.conf)
            .stdin(Stdio::null())
            .stdout(out.try_clone().unwrap())
            .stderr(out)
            .spawn()
            .unwrap_or_else(|e| panic!("start {name}: {e}"));
        self.daemons.push(child);
    }

    /// A Slurm client command against this cluster; its stdout.
    fn run(&self, cmd: &str, args: &[&str]) -> String {
        let o = Command::new(cmd)
            .args(args)
            .env("SLURM_CONF", &self.conf)
            .output()
            .unwrap_or_else(|e| panic!("{cmd}: {e}"));
        String::from_utf8_lossy(&o.stdout).into_owned()
    }

    /// The ids of the jobs in the queue.
    fn queue(&self) -> Vec<String> {
        self.run("squeue", &["-h", "-o", "%i"])
            .split_whitespace()
            .map(str::to_owned)
            .collect()
    }

    /// Wait until every job has left the queue (done, failed or cancelled).
    fn drain(&self, limit: Duration) {
        wait_for("an empty Slurm queue", limit, || self.queue().is_empty());
    }

    /// `scripts/slurm_brdf.sh ARGS` with this build's roks, against this cluster.
    fn script(&self, args: &[&str], env: &[(&str, &str)]) -> Output {
        Command::new("bash")
            .arg(root().join("scripts/slurm_brdf.sh"))
            .args(args)
            .env("SLURM_CONF", &self.conf)
            .env("ROKS", env!("CARGO_BIN_EXE_roks"))
            .envs(env.iter().copied())
            .current_dir(&self.dir)
            .output()
            .expect("run bash")
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        // Jobs first (their processes belong to slurmd), then the daemons.
        let jobs = self.queue();
        if !jobs.is_empty() {
            let _ = Command::new("scancel")
                .args(&jobs)
                .env("SLURM_CONF", &self.conf)
                .status();
            let start = Instant::now();
            while !self.queue().is_empty() && start.elapsed() < Duration::from_secs(20) {
                std::thread::sleep(Duration::from_millis(100));
            }
        }
        for child in self.daemons.iter_mut().rev() {
            if let Some(pid) = Pid::from_raw(child.id() as i32) {
                let _ = kill_process(pid, Signal::TERM);
            }
            let start = Instant::now();
            while matches!(child.try_wait(), Ok(None)) && start.elapsed() < Duration::from_secs(10)
            {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
        if std::thread::panicking() {
            eprintln!("slurm: logs kept in {}", self.dir.display());
        } else {
            let _ = fs::remove_dir_all(&self.dir);
        }
    }
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The script refused bad input: exit status 2, one line on stderr holding
/// every string of `expect`, nothing submitted, no shard folder.
fn assert_refused(cluster: &Cluster, case: &str, o: &Output, out: &Path, expect: &[&str]) {
    assert_one_line_refusal(case, o, out, expect);
    assert!(cluster.queue().is_empty(), "{case}: jobs were submitted");
}

/// Exit status 2, one line on stderr holding every string of `expect`, and
/// no shard folder `out.shards` (what was submitted is the caller's check).
fn assert_one_line_refusal(case: &str, o: &Output, out: &Path, expect: &[&str]) {
    let stderr = text(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{case}: {}, stderr {stderr}",
        o.status
    );
    let line = stderr
        .strip_suffix('\n')
        .unwrap_or_else(|| panic!("{case}: {stderr:?}"));
    assert!(!line.contains('\n'), "{case}: not one line: {stderr:?}");
    for e in expect {
        assert!(line.contains(e), "{case}: no `{e}` in {line:?}");
    }
    let shards = PathBuf::from(format!("{}.shards", out.display()));
    assert!(!shards.exists(), "{case}: {} was created", shards.display());
}

/// The merged folder `out` holds the single run's bytes: its tables, the
/// Zemax export (the merge exports what `--export` asked of the run) and
/// the surface's picture.
fn assert_same_as_single(case: &str, out: &Path, single: &Path) {
    for name in ["brdf.csv", "inplane.csv", "brdf.bsdf", "surface.png"] {
        assert!(
            read(out, name) == read(single, name),
            "{case}: {name} differs from the single run's"
        );
    }
    assert_eq!(
        summary_without_timing(out),
        summary_without_timing(single),
        "{case}: summary.json differs beyond timings"
    );
}

/// The job array id from the script's "as job array N" line.
fn array_id(o: &Output) -> String {
    let stdout = text(&o.stdout);
    stdout
        .split("as job array ")
        .nth(1)
        .and_then(|s| s.split(|c: char| !c.is_ascii_digit()).next())
        .unwrap_or_else(|| panic!("no job array id in {stdout:?}"))
        .to_owned()
}

/// The pid of the running `roks brdf` whose arguments include `--out out`.
fn roks_writing(out: &Path) -> Option<i32> {
    let out = out.as_os_str().as_encoded_bytes();
    fs::read_dir("/proc").ok()?.flatten().find_map(|e| {
        let pid: i32 = e.file_name().to_str()?.parse().ok()?;
        let cmdline = fs::read(e.path().join("cmdline")).ok()?;
        let args: Vec<&[u8]> = cmdline.split(|&b| b == 0).collect();
        let writes = args.windows(2).any(|w| w[0] == b"--out" && w[1] == out);
        (writes && args.first().is_some_and(|a| a.ends_with(b"roks"))).then_some(pid)
    })
}

#[test]
fn slurm_runs_merge_into_the_single_run_and_recover_from_a_killed_shard() {
    if !slurm_available() {
        return;
    }
    let started = Instant::now();
    let cluster = Cluster::start();
    eprintln!(
        "slurm: cluster up in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    let scene = root().join("scenes/default.toml");
    let scene = scene.to_str().unwrap();
    let work = cluster.dir.join("runs");
    fs::create_dir(&work).unwrap();
    let path = |name: &str| work.join(name);
    let s = |p: &Path| p.to_str().unwrap().to_owned();

    // The single run everything is compared with.
    let single = path("single");
    let o = Command::new(env!("CARGO_BIN_EXE_roks"))
        .args([
            "brdf",
            scene,
            "-q",
            "--photons",
            PHOTONS,
            "--export",
            "zemax",
            "--out",
            &s(&single),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "single run: {}", text(&o.stderr));

    // Bad input, refused before anything is submitted.
    let bad = path("bad");
    let bad_out = s(&bad);
    let refused = |case: &str, args: &[&str], env: &[(&str, &str)], expect: &[&str]| {
        let mut all = vec![args[0], bad_out.as_str()];
        all.extend_from_slice(&args[1..]);
        assert_refused(&cluster, case, &cluster.script(&all, env), &bad, expect);
    };
    refused(
        "no scene",
        &["nowhere.toml", "4"],
        &[],
        &["nowhere.toml", "no such scene file"],
    );
    refused(
        "more shards than batches",
        &[scene, "9", "--photons", PHOTONS],
        &[],
        &["--shard", "9 shards but only 8 batches"],
    );
    refused(
        "options without SHARDS, default 8 > 1 batch",
        &[scene, "--photons", "4096"],
        &[],
        &["--shard", "8 shards but only 1 batches"],
    );
    refused(
        "an option roks refuses",
        &[scene, "2", "--photons", "0"],
        &[],
        &["--photons"],
    );
    refused(
        "more cores than a node has",
        &[scene, "2", "--photons", PHOTONS],
        &[("CPUS", "100000")],
        &["CPUS", "100000", "at most"],
    );
    refused("--out given", &[scene, "2", "--out", "x"], &[], &["--out"]);
    let not_result = path("not-a-result");
    fs::create_dir(&not_result).unwrap();
    fs::write(not_result.join("notes.txt"), "mine").unwrap();
    let o = cluster.script(&[scene, &s(&not_result), "2", "--photons", PHOTONS], &[]);
    assert_refused(
        &cluster,
        "OUT holds other files",
        &o,
        &not_result,
        &["not-a-result", "neither empty nor a roks result"],
    );

    // (1) A clean run: the default 8 shards, 2 at a time.
    let t = Instant::now();
    let clean = path("clean");
    let o = cluster.script(
        &[scene, &s(&clean), "--photons", PHOTONS, "--export", "zemax"],
        &[("CPUS", "1")],
    );
    assert!(o.status.success(), "clean run: {}", text(&o.stderr));
    cluster.drain(Duration::from_secs(120));
    let status = cluster.script(&["status", &s(&clean)], &[]);
    let report = text(&status.stdout);
    assert_eq!(
        status.status.code(),
        Some(0),
        "clean status: {report}{}",
        text(&status.stderr)
    );
    assert!(
        report.contains("done: 8 of 8") && report.contains("merged: "),
        "{report}"
    );
    assert_same_as_single("clean run", &clean, &single);
    eprintln!(
        "slurm: clean run of 8 shards merged in {:.1} s",
        t.elapsed().as_secs_f64()
    );

    // A second submission into the same OUT finds the first run's shards.
    let o = cluster.script(&[scene, &s(&clean), "4", "--photons", PHOTONS], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("earlier run"),
        "{}",
        text(&o.stderr)
    );
    assert!(
        cluster.queue().is_empty(),
        "resubmission into a used OUT submitted jobs"
    );

    // (2) Shard 1 killed mid-run, shard 3 cancelled before it started.
    let t = Instant::now();
    let broken = path("broken");
    let o = cluster.script(
        &[
            scene,
            &s(&broken),
            "4",
            "--photons",
            PHOTONS,
            "--export=zemax",
        ],
        &[("CPUS", "1")],
    );
    assert!(o.status.success(), "run to break: {}", text(&o.stderr));
    let array = array_id(&o);
    cluster.run("scancel", &[&format!("{array}_3")]);
    let shard1 = PathBuf::from(format!("{}.shards/001", broken.display()));
    let mut victim = None;
    wait_for("shard 1's roks", Duration::from_secs(60), || {
        victim = roks_writing(&shard1);
        victim.is_some()
    });
    kill_process(Pid::from_raw(victim.unwrap()).unwrap(), Signal::KILL).expect("kill -9 shard 1");
    // Slurm cancels the merge: the queue empties instead of pending forever.
    cluster.drain(Duration::from_secs(60));
    assert!(
        !broken.join("brdf.csv").exists(),
        "a merge ran without shards 1 and 3"
    );

    let status = cluster.script(&["status", &s(&broken)], &[]);
    let report = text(&status.stdout);
    assert_eq!(
        status.status.code(),
        Some(1),
        "status after the kill: {report}{}",
        text(&status.stderr)
    );
    assert!(report.contains("done: 2 of 4"), "{report}");
    assert!(
        report.lines().any(|l| l.starts_with("failed: 001")),
        "{report}"
    );
    assert!(
        report.lines().any(|l| l.starts_with("missing: 003")),
        "{report}"
    );
    let command = report.lines().last().unwrap().trim();
    assert!(
        command.ends_with(&format!("resubmit {} 1,3", s(&broken))),
        "{report}"
    );

    // Shards that are done are not resubmitted; a folder without a run has
    // no status.
    let broken_out = s(&broken);
    for (args, expect) in [
        (vec!["resubmit", &broken_out, "0"], "shard 0 is done"),
        (vec!["status", &bad_out], "no run of slurm_brdf.sh"),
    ] {
        let o = cluster.script(&args, &[]);
        let stderr = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains(expect) && stderr.lines().count() == 1,
            "{args:?}: {stderr}"
        );
    }
    assert!(
        cluster.queue().is_empty(),
        "a refused resubmission submitted jobs"
    );

    // The printed command, as a user would paste it.
    let o = Command::new("bash")
        .args(["-c", command])
        .env("SLURM_CONF", &cluster.conf)
        .output()
        .unwrap();
    assert!(o.status.success(), "{command}: {}", text(&o.stderr));
    cluster.drain(Duration::from_secs(120));
    let status = cluster.script(&["status", &s(&broken)], &[]);
    let report = text(&status.stdout);
    assert_eq!(
        status.status.code(),
        Some(0),
        "status after resubmitting: {report}"
    );
    assert!(
        report.contains("done: 4 of 4") && report.contains("merged: "),
        "{report}"
    );
    assert_same_as_single("killed and resubmitted", &broken, &single);
    eprintln!(
        "slurm: killed, resubmitted and merged in {:.1} s",
        t.elapsed().as_secs_f64(),
    );

    // (3) An object scene: the same script runs `roks trace` shards.
    let t = Instant::now();
    let tube = root().join("scenes/baffled-tube-10.toml");
    let tube = tube.to_str().unwrap();
    let tube_single = path("tube-single");
    let o = Command::new(env!("CARGO_BIN_EXE_roks"))
        .args(["trace", tube, "-q", "--photons", TUBE_PHOTONS])
        .args(["--out", &s(&tube_single)])
        .output()
        .unwrap();
    assert!(o.status.success(), "single trace: {}", text(&o.stderr));
    refused(
        "more object shards than batches",
        &[tube, "4", "--photons", TUBE_PHOTONS],
        &[],
        &["roks trace refuses", "4 shards but only 3 batches"],
    );
    let tube_out = path("tube");
    let o = cluster.script(
        &[tube, &s(&tube_out), "3", "--photons", TUBE_PHOTONS],
        &[("CPUS", "1")],
    );
    assert!(o.status.success(), "object run: {}", text(&o.stderr));
    cluster.drain(Duration::from_secs(120));
    let status = cluster.script(&["status", &s(&tube_out)], &[]);
    let report = text(&status.stdout);
    assert_eq!(status.status.code(), Some(0), "object status: {report}");
    assert!(
        report.contains("done: 3 of 3")
            && report.contains("merged: ")
            && report.contains("roks trace options"),
        "{report}"
    );
    for name in ["reflectance.csv", "farfield.csv", "reflectance.png"] {
        assert!(
            read(&tube_out, name) == read(&tube_single, name),
            "object run: {name} differs from the single run's"
        );
    }
    assert_eq!(
        summary_without_timing(&tube_out),
        summary_without_timing(&tube_single),
        "object run: summary.json differs beyond timings"
    );
    eprintln!(
        "slurm: object scene in 3 shards merged in {:.1} s; whole test {:.1} s",
        t.elapsed().as_secs_f64(),
        started.elapsed().as_secs_f64()
    );
}

/// The script's own checks without a Slurm cluster: fake `sbatch`,
/// `squeue`, `scancel` and `sinfo` on `PATH` (each logs its call; `sbatch`
/// prints a job id). Exports the merge would refuse (an unknown format, rgl
/// of the light azimuths [0, 90], pbsdf without a Mueller tally) are refused
/// before anything is submitted, with roks's own reason; a clean run is
/// submitted (checked by `roks brdf --check`, nothing traced); a `sinfo`
/// that cannot reach the controller is named in one line, exit status 2
/// (it used to end the script with status 1 and no message).
#[test]
fn script_checks_exports_and_sinfo_before_submitting() {
    let dir = std::env::temp_dir().join(format!("roks-slurm-fake-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    let bin = dir.join("bin");
    fs::create_dir_all(&bin).unwrap();
    let calls = dir.join("calls.log");
    let fake = |name: &str, body: &str| {
        let path = bin.join(name);
        fs::write(
            &path,
            format!(
                "#!/bin/sh\necho \"{name} $*\" >> '{}'\n{body}\n",
                calls.display()
            ),
        )
        .unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(0o755)).unwrap();
    };
    fake("sbatch", "echo 42");
    fake("squeue", "exit 0");
    fake("scancel", "exit 0");
    let sinfo_up = "case \"$*\" in *%P*) echo 'debug*' ;; *) echo 2 ;; esac";
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let scene = root().join("scenes/default.toml");
    let run = |case: &str, args: &[&str]| -> (Output, PathBuf) {
        let out = dir.join(case);
        let mut all = vec![scene.to_str().unwrap(), out.to_str().unwrap()];
        all.extend_from_slice(args);
        let _ = fs::remove_file(&calls);
        let o = Command::new(root().join("scripts/slurm_brdf.sh"))
            .args(&all)
            .env("PATH", &path)
            .env("ROKS", env!("CARGO_BIN_EXE_roks"))
            .env_remove("SBATCH_PARTITION")
            .env_remove("CPUS")
            .output()
            .unwrap();
        (o, out)
    };
    let refused = |case: &str, o: &Output, out: &Path, expect: &[&str]| {
        assert_one_line_refusal(case, o, out, expect);
        let log = fs::read_to_string(&calls).unwrap_or_default();
        assert!(!log.contains("sbatch"), "{case}: submitted: {log}");
    };

    fake(
        "sinfo",
        "echo 'sinfo: error: Unable to contact slurm controller (connect failure)' >&2; exit 1",
    );
    let (o, out) = run("sinfo-down", &["4", "--photons", "40960"]);
    refused(
        "sinfo down",
        &o,
        &out,
        &[
            "sinfo",
            "Unable to contact slurm controller",
            "exit status 1",
        ],
    );

    fake("sinfo", sinfo_up);
    for (case, args, expect) in [
        (
            "gltf",
            &["--export", "gltf"][..],
            &["roks brdf refuses the run", "--export", "gltf"][..],
        ),
        (
            "rgl-0-90",
            &["--phi", "0,90", "--export", "rgl"][..],
            &["roks brdf refuses the run", "--export rgl", "light.phi_deg"][..],
        ),
        (
            "pbsdf-no-mueller",
            &["--export=pbsdf"][..],
            &["roks brdf refuses the run", "--export pbsdf", "mueller"][..],
        ),
    ] {
        let mut all = vec!["4", "--photons", "40960"];
        all.extend_from_slice(args);
        let (o, out) = run(case, &all);
        refused(case, &o, &out, expect);
    }

    // A run the checks accept is submitted: the shards and the merge.
    let (o, out) = run("clean", &["4", "--photons", "40960", "--export", "zemax"]);
    assert!(o.status.success(), "clean: {}", text(&o.stderr));
    let log = fs::read_to_string(&calls).unwrap();
    assert_eq!(log.matches("sbatch ").count(), 2, "{log}");
    assert!(log.contains("--array=0-3"), "{log}");
    assert!(
        log.contains("merge") && log.contains("--export zemax"),
        "{log}"
    );
    assert!(!out.exists(), "the check wrote {}", out.display());
    let _ = fs::remove_dir_all(&dir);
}
