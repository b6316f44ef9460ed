//! A real single-node Slurm cluster on this machine runs a split render through the scripts of
//! `farm/slurm/`: photon maps, 4 tiles as a job array, and the merge as a dependent job. The
//! merged image must equal a single-process render bit for bit. Failure drill: one array task
//! fails (its output path is blocked by a folder), so the merge job is cancelled rather than
//! left pending; re-running that index and the merge gives the identical image. Then 2 tiles x
//! 2 pass ranges of a 3-pass progressive render, against 3 passes in one process.
//!
//! Debian's `slurmctld`, `slurmd`, `slurm-client` and `munge` are installed when missing; the
//! test is skipped, with a message saying so, only when they cannot be installed. Both daemons
//! run in the foreground (`-D`) as children of the test with a generated `slurm.conf` in a
//! temporary folder (no authentication, free ports), and are shut down with
//! `scontrol shutdown`; only their process ids are ever killed.

mod common;

use photondiff::render::part::read_part;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const EXE: &str = env!("CARGO_BIN_EXE_photondiff");
const ROOT: &str = env!("CARGO_MANIFEST_DIR");
const PHOTONS: [&str; 4] = ["--photons", "20000", "--caustic-photons", "5000"];

fn have(binary: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {binary}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Installs the Slurm packages when missing; `Err` says why they cannot be.
fn install_slurm() -> Result<(), String> {
    if ["slurmctld", "slurmd", "sbatch", "munge"]
        .iter()
        .all(|b| have(b))
    {
        return Ok(());
    }
    let root = Command::new("id")
        .arg("-u")
        .output()
        .map(|o| o.stdout == b"0\n");
    let sudo = if root.unwrap_or(false) {
        ""
    } else {
        "sudo -n "
    };
    let script = format!(
        "{sudo}apt-get update -qq && DEBIAN_FRONTEND=noninteractive {sudo}apt-get install -y \
         --no-install-recommends slurmctld slurmd slurm-client munge"
    );
    let start = Instant::now();
    let out = Command::new("sh")
        .args(["-c", &script])
        .output()
        .map_err(|e| e.to_string())?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(err.lines().last().unwrap_or("apt-get failed").to_string());
    }
    eprintln!(
        "slurm: packages installed in {:.1} s (apt-get update and install)",
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// A free TCP port on this machine (the kernel's choice; free again once the listener drops).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The cluster: its configuration and the two daemons this test started.
struct Cluster {
    conf: PathBuf,
    daemons: Vec<Child>,
}

impl Cluster {
    fn start(dir: &Path) -> Cluster {
        let user = String::from_utf8(Command::new("id").arg("-un").output().unwrap().stdout)
            .unwrap()
            .trim()
            .to_string();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        for sub in ["state", "spool"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
        }
        let d = dir.display();
        let (ctld_port, d_port) = (free_port(), free_port());
        let conf = dir.join("slurm.conf");
        std::fs::write(
            &conf,
            format!(
                "ClusterName=photondiff\nSlurmctldHost=localhost\nSlurmUser={user}\n\
                 SlurmdUser={user}\nAuthType=auth/none\nCredType=cred/none\n\
                 ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
                 SelectType=select/cons_tres\nSelectTypeParameters=CR_CPU\n\
                 SlurmctldPort={ctld_port}\nSlurmdPort={d_port}\nStateSaveLocation={d}/state\n\
                 SlurmdSpoolDir={d}/spool\nSlurmctldPidFile={d}/slurmctld.pid\n\
                 SlurmdPidFile={d}/slurmd.pid\nSlurmctldLogFile={d}/slurmctld.log\n\
                 SlurmdLogFile={d}/slurmd.log\nMpiDefault=none\nReturnToService=2\n\
                 SchedulerType=sched/backfill\nJobCompType=jobcomp/none\n\
                 AccountingStorageType=accounting_storage/none\n\
                 JobAcctGatherType=jobacct_gather/none\nMinJobAge=600\n\
                 NodeName=localhost NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\n\
                 PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP\n"
            ),
        )
        .unwrap();
        let spawn = |args: &[&str], log: &str| {
            let log = std::fs::File::create(dir.join(log)).unwrap();
            Command::new(args[0])
                .args(&args[1..])
                .env("SLURM_CONF", &conf)
                .stdout(log.try_clone().unwrap())
                .stderr(log)
                .spawn()
                .unwrap_or_else(|e| panic!("cannot start {}: {e}", args[0]))
        };
        let c = conf.to_str().unwrap();
        let mut cluster = Cluster {
            daemons: vec![spawn(&["slurmctld", "-D", "-f", c], "slurmctld.out")],
            conf: conf.clone(),
        };
        cluster.daemons.push(spawn(
            &["slurmd", "-D", "-N", "localhost", "-f", c],
            "slurmd.out",
        ));
        let start = Instant::now();
        while cluster.run(&["sinfo", "-h", "-o", "%T"]).trim() != "idle" {
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "the Slurm node did not become idle; logs in {d}"
            );
            std::thread::sleep(Duration::from_millis(200));
        }
        eprintln!(
            "slurm: node idle {:.1} s after start",
            start.elapsed().as_secs_f64()
        );
        cluster
    }

    /// Runs a Slurm client command (or a script calling them) against this cluster.
    fn run(&self, args: &[&str]) -> String {
        let out = Command::new(args[0])
            .args(&args[1..])
            .env("SLURM_CONF", &self.conf)
            .env("PHOTONDIFF", EXE)
            .output()
            .unwrap();
        if !out.status.success() {
            eprintln!("{args:?}: {}", String::from_utf8_lossy(&out.stderr));
        }
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    /// Submits through farm/slurm/submit.sh; returns the merge job's id and the image's path.
    /// `render` options go after `--`.
    fn submit(
        &self,
        scene: &Path,
        out: &Path,
        extra: &[&str],
        render: &[&str],
    ) -> (String, PathBuf) {
        let submit = format!("{ROOT}/farm/slurm/submit.sh");
        let mut args = vec![submit.as_str(), "--tiles", "4", "--cpus-per-task", "1"];
        args.extend(extra);
        args.extend(PHOTONS);
        args.extend([scene.to_str().unwrap(), out.to_str().unwrap()]);
        if !render.is_empty() {
            args.push("--");
            args.extend(render);
        }
        let printed = self.run(&args);
        let field = |name: &str| {
            printed
                .lines()
                .find_map(|l| l.strip_prefix(name))
                .unwrap_or_else(|| panic!("submit.sh printed no {name:?}: {printed}"))
                .trim()
                .to_string()
        };
        assert!(printed.contains("tile jobs: "), "{printed}");
        (field("merge job:"), PathBuf::from(field("image:")))
    }

    /// Submits a job that does nothing and returns how long it stayed pending: the
    /// scheduler's latency, before any photondiff work.
    fn start_latency(&self) -> f64 {
        let start = Instant::now();
        let id = self.run(&[
            "sbatch",
            "--parsable",
            "--output=/dev/null",
            "--wrap",
            "true",
        ]);
        let id = id.trim().to_string();
        assert!(!id.is_empty(), "sbatch --wrap true printed no job id");
        loop {
            // `-t all`: by default squeue leaves out finished jobs, and a job that finished
            // between two polls would look pending until the time limit.
            let state = self.run(&["squeue", "-h", "-t", "all", "-j", &id, "-o", "%T"]);
            if !matches!(state.trim(), "PENDING" | "") {
                break;
            }
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "job {id} still pending after 60 s"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        let latency = start.elapsed().as_secs_f64();
        assert_eq!(self.wait(&id), "COMPLETED");
        latency
    }

    /// Waits until job `id` has left the queue and returns its final state.
    fn wait(&self, id: &str) -> String {
        let start = Instant::now();
        loop {
            let show = self.run(&["scontrol", "show", "job", id]);
            let state = show
                .split_whitespace()
                .find_map(|w| w.strip_prefix("JobState="))
                .unwrap_or("")
                .to_string();
            if !matches!(
                state.as_str(),
                "PENDING" | "RUNNING" | "CONFIGURING" | "COMPLETING" | ""
            ) {
                eprintln!(
                    "slurm: job {id} {state} after {:.1} s",
                    start.elapsed().as_secs_f64()
                );
                return state;
            }
            assert!(
                start.elapsed() < Duration::from_secs(300),
                "job {id} still {state} after 300 s: {show}"
            );
            std::thread::sleep(Duration::from_millis(250));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        self.run(&["scontrol", "shutdown"]);
        let start = Instant::now();
        for daemon in &mut self.daemons {
            while daemon.try_wait().ok().flatten().is_none() {
                if start.elapsed() > Duration::from_secs(20) {
                    // Only the processes this test started, by their ids.
                    let _ = daemon.kill();
                    let _ = daemon.wait();
                    break;
                }
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

fn bits(path: &Path) -> Vec<[u64; 3]> {
    read_part(path)
        .unwrap()
        .film
        .pixels
        .iter()
        .map(|p| p.to_array().map(f64::to_bits))
        .collect()
}

/// The image of `scene` rendered in one process with `extra` and the test's photon counts, as
/// bits (written to `out`).
fn single_process(scene: &Path, out: &Path, extra: &[&str]) -> Vec<[u64; 3]> {
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.push("--quiet");
    args.extend(extra);
    args.extend(PHOTONS);
    assert!(Command::new(EXE).args(&args).status().unwrap().success());
    bits(out)
}

#[test]
fn a_slurm_job_array_renders_the_single_process_image_and_recovers_from_a_failed_tile() {
    if let Err(why) = install_slurm() {
        common::unavailable(&format!(
            "the Slurm packages are missing and cannot be installed: {why}"
        ));
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The canonical scene, small enough to render in seconds per tile.
    let text = std::fs::read_to_string(format!("{ROOT}/scenes/caustic-sphere.toml"))
        .unwrap()
        .replace("width = 640", "width = 160")
        .replace("height = 480", "height = 128");
    let scene = d.join("caustic-sphere.toml");
    std::fs::write(&scene, text).unwrap();
    let reference = single_process(&scene, &d.join("single.exr"), &[]);

    let cluster = Cluster::start(&d.join("slurm"));
    eprintln!(
        "slurm: a job started {:.2} s after submission",
        cluster.start_latency()
    );

    // All tiles succeed.
    // A % in OUTDIR is no pattern of sbatch's --output: the logs land where they should.
    let (merge, image) = cluster.submit(&scene, &d.join("run 100%x"), &[], &[]);
    assert_eq!(cluster.wait(&merge), "COMPLETED");
    assert!(
        bits(&image) == reference,
        "the Slurm image differs from one process"
    );

    // Tile 2 fails: the merge job is cancelled, not left pending, and writes nothing.
    let run = d.join("drill");
    std::fs::create_dir_all(run.join("parts/tile-2-of-4.exr")).unwrap();
    let (merge, image) = cluster.submit(&scene, &run, &[], &[]);
    assert_eq!(cluster.wait(&merge), "CANCELLED");
    assert!(!image.exists());
    // Re-running only index 2 (with the photon maps already there) and merging again.
    std::fs::remove_dir(run.join("parts/tile-2-of-4.exr")).unwrap();
    let (merge, image2) = cluster.submit(&scene, &run, &["--array", "2"], &[]);
    assert_eq!(image2, image);
    assert_eq!(cluster.wait(&merge), "COMPLETED");
    assert!(
        bits(&image) == reference,
        "the re-run image differs from one process"
    );

    // Tiles and pass ranges: 2 tiles x 2 ranges of 3 passes, against 3 passes in one process.
    let progressive = single_process(&scene, &d.join("progressive.exr"), &["--passes", "3"]);
    let extra = ["--tiles", "2", "--passes", "3", "--pass-ranges", "2"];
    let (merge, image) = cluster.submit(&scene, &d.join("passes"), &extra, &[]);
    assert_eq!(cluster.wait(&merge), "COMPLETED");
    assert!(
        d.join("passes/parts/tile-1-of-2.passes-1-3.exr").exists(),
        "task 3 renders tile 1, passes 1..3"
    );
    assert!(
        bits(&image) == progressive,
        "the pass-range image differs from one process"
    );

    // Another estimator after `--`: the photons job traces the maps its render would (the
    // thesis's defaults for `pd`, not the default render's), which the tiles accept.
    let pd = single_process(&scene, &d.join("pd.exr"), &["--estimator", "pd"]);
    let (merge, image) = cluster.submit(&scene, &d.join("pd"), &[], &["--estimator", "pd"]);
    assert_eq!(cluster.wait(&merge), "COMPLETED");
    assert!(
        bits(&image) == pd,
        "the Slurm image of --estimator pd differs from one process"
    );
}
