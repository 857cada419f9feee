//! What an image planner leaves on the host (its container, and the private directory that holds its socket) goes
//! when its worker dies, however it dies.
//!
//! - Every planner container carries the label [`LABEL`]`=`[`Owner`] and every private directory is named
//!   `vb-planner-<owner>-<random>`: the worker that made it (this boot of the machine, the worker's PID namespace,
//!   its process id and that process's start time, so a reused process id is not taken for the worker).
//! - A **watchdog** per image episode ([`Watchdog`]): a `/bin/sh` started before the container, in a process group
//!   of its own, ignoring the terminal and termination signals, with no death signal, that waits on a pipe whose
//!   only writer is the worker. The pipe closes when the episode ends or the worker dies, a SIGKILL included (the
//!   kernel closes a dead process's descriptors); the watchdog then runs `docker rm -f` on the container, removes
//!   the directory and exits. It is a shell, not the worker's own binary, because it must not depend on that binary
//!   (replaced by an upgrade, or `vb-submit`), must inherit nothing but the pipe and `/dev/null` (every other
//!   descriptor is marked close-on-exec before it executes: no socket or supervisor's pipe of the worker stays open
//!   in it), and has nothing else to do. Its environment is only `PATH`, `HOME` and `DOCKER_*`: not the token.
//! - A **sweep** at the worker's start ([`sweep`]) removes the containers and directories of dead workers of this
//!   machine that a watchdog did not (the machine crashed or rebooted, a watchdog was killed): never those of a
//!   worker it cannot prove dead (another PID namespace, another machine sharing the Docker daemon, a process it
//!   cannot inspect).

use std::io::Write;
use std::os::fd::OwnedFd;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

/// The label on every planner container, naming its worker ([`Owner`]).
pub const LABEL: &str = "vb.worker";
/// The prefix of every private planner directory's name in the temporary directory.
pub const DIR_PREFIX: &str = "vb-planner-";

/// The process that owns planner containers and directories: this boot of the machine (`boot` is the kernel's boot
/// id, without dashes), the PID namespace's inode, the process id and its start time (clock ticks after boot).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Owner {
    boot: String,
    pidns: u64,
    pid: u32,
    start: u64,
}

/// Whether an owner still runs, as far as this process can tell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fate {
    Alive,
    Dead,
    /// Not provably dead: another PID namespace or machine, or a process this one cannot inspect.
    Unknown,
}

/// How many leftovers a [`sweep`] removed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Swept {
    pub containers: usize,
    pub dirs: usize,
}

impl Owner {
    /// This process.
    pub fn current() -> Result<&'static Owner, String> {
        static ME: OnceLock<Result<Owner, String>> = OnceLock::new();
        ME.get_or_init(|| {
            let boot = std::fs::read_to_string("/proc/sys/kernel/random/boot_id")
                .map_err(|e| format!("cannot read the boot id: {e}"))?
                .trim()
                .replace('-', "");
            let ns = std::fs::read_link("/proc/self/ns/pid")
                .map_err(|e| format!("cannot read the PID namespace: {e}"))?;
            let pidns = ns
                .to_string_lossy()
                .trim_start_matches("pid:[")
                .trim_end_matches(']')
                .parse()
                .map_err(|_| format!("unexpected PID namespace `{}`", ns.display()))?;
            let pid = std::process::id();
            let start = start_time("self").ok_or("cannot read this process's start time")?;
            Ok(Owner {
                boot,
                pidns,
                pid,
                start,
            })
        })
        .as_ref()
        .map_err(Clone::clone)
    }

    /// The container label's value: `BOOT.PIDNS.PID.START`.
    pub fn label(&self) -> String {
        format!("{}.{}.{}.{}", self.boot, self.pidns, self.pid, self.start)
    }

    /// The part of a private directory's name that names its owner: the label with the boot id's first 8 digits
    /// (the socket's path must stay under 108 bytes).
    pub fn dir_tag(&self) -> String {
        format!(
            "{}.{}.{}.{}",
            boot_prefix(&self.boot),
            self.pidns,
            self.pid,
            self.start
        )
    }

    /// Parses [`Owner::label`] or [`Owner::dir_tag`].
    pub fn parse(text: &str) -> Option<Owner> {
        let mut it = text.split('.');
        let boot = it.next()?;
        let owner = Owner {
            boot: boot.to_string(),
            pidns: it.next()?.parse().ok()?,
            pid: it.next()?.parse().ok()?,
            start: it.next()?.parse().ok()?,
        };
        let hex = !boot.is_empty() && boot.bytes().all(|b| b.is_ascii_hexdigit());
        (hex && it.next().is_none()).then_some(owner)
    }

    /// Whether this owner runs, judged by `me`. `local` says the evidence lies in this machine's own temporary
    /// directory, so an owner of another boot is dead (a container label may come from another machine sharing
    /// the Docker daemon: there another boot proves nothing).
    pub fn fate(&self, me: &Owner, local: bool) -> Fate {
        if boot_prefix(&self.boot) != boot_prefix(&me.boot)
            || (self.boot.len() > 8 && self.boot != me.boot)
        {
            return if local { Fate::Dead } else { Fate::Unknown };
        }
        if self.pidns != me.pidns {
            return Fate::Unknown;
        }
        if self.pid == me.pid {
            return if self.start == me.start {
                Fate::Alive
            } else {
                Fate::Dead
            };
        }
        match start_time(&self.pid.to_string()) {
            Some(s) if s == self.start => Fate::Alive,
            Some(_) => Fate::Dead,
            // Hidden from this process (`hidepid`), or gone: only "no such process" proves it gone.
            None => match nix::sys::signal::kill(nix::unistd::Pid::from_raw(self.pid as i32), None)
            {
                Err(nix::errno::Errno::ESRCH) => Fate::Dead,
                _ => Fate::Unknown,
            },
        }
    }
}

fn boot_prefix(boot: &str) -> &str {
    boot.get(..8).unwrap_or(boot)
}

/// Field 22 of `/proc/PID/stat`: the process's start time.
fn start_time(pid: &str) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name (field 2) may hold spaces and parentheses: the fields after it follow the last `)`.
    let rest = &stat[stat.rfind(')')? + 1..];
    rest.split_whitespace().nth(19)?.parse().ok()
}

/// A fresh private directory's path for a planner of this process (not yet made): `vb-planner-<owner>-<random>` in
/// the temporary directory.
pub fn private_dir_path() -> Result<PathBuf, String> {
    let mut id = [0u8; 8];
    getrandom::getrandom(&mut id).map_err(|e| e.to_string())?;
    let random: String = id.iter().map(|b| format!("{b:02x}")).collect();
    let owner = Owner::current()?.dir_tag();
    Ok(std::env::temp_dir().join(format!("{DIR_PREFIX}{owner}-{random}")))
}

/// The owner named by a private directory's name, if it has one.
fn dir_owner(name: &str) -> Option<Owner> {
    let rest = name.strip_prefix(DIR_PREFIX)?;
    let (tag, random) = rest.rsplit_once('-')?;
    (!random.is_empty() && random.bytes().all(|b| b.is_ascii_hexdigit()))
        .then(|| Owner::parse(tag))
        .flatten()
}

/// The watchdog of one image planner: removes its container and directory once [`Watchdog`] is dropped or the
/// worker dies. See the [module](self) for why it is a shell.
#[derive(Debug)]
pub struct Watchdog {
    /// The pipe's only writer: closed when this is dropped or the worker dies.
    pipe: std::fs::File,
}

/// The watchdog's script: `$1` the container, `$2` the directory. A line on the pipe means the worker saw the
/// `docker run` client exit (the container exists or never will); end of file without one means the client may have
/// died while asking for the container, whose creation the daemon may finish after a first removal: a second one,
/// two seconds later, catches it.
const SCRIPT: &str = "trap '' HUP INT QUIT TERM PIPE
if read -r _; then again=; else again=1; fi
docker rm -f \"$1\" >/dev/null 2>&1
if [ -n \"$again\" ]; then sleep 2; docker rm -f \"$1\" >/dev/null 2>&1; fi
rm -rf -- \"$2\"";

impl Watchdog {
    /// Starts the watchdog of container `name` and directory `dir` (both may not exist yet).
    pub fn spawn(name: &str, dir: &Path) -> std::io::Result<Watchdog> {
        let (read, write) = pipe()?;
        // Only what `docker` needs to reach the worker's daemon: not the worker's token.
        let env = std::env::vars_os().filter(|(k, _)| {
            let k = k.to_string_lossy();
            k == "PATH" || k == "HOME" || k.starts_with("DOCKER_")
        });
        let mut command = Command::new("/bin/sh");
        // SAFETY: the closure runs in the forked child before `exec` and makes only async-signal-safe system calls.
        #[allow(unsafe_code)]
        unsafe {
            command.pre_exec(cloexec_above_stdio);
        }
        let mut child = command
            .args(["-c", SCRIPT, "vb-planner-watchdog", name])
            .arg(dir)
            .env_clear()
            .envs(env)
            .current_dir("/")
            .process_group(0)
            .stdin(Stdio::from(read))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()?;
        // Reaped here while the worker lives; by init (or a subreaper) after it died.
        std::thread::spawn(move || child.wait());
        Ok(Watchdog {
            pipe: std::fs::File::from(write),
        })
    }

    /// The `docker run` client has exited: one removal is enough.
    pub fn client_exited(&mut self) {
        let _ = self.pipe.write_all(b"exited\n");
    }
}

/// In the watchdog's forked child before `exec`: marks every descriptor above the standard ones close-on-exec. The
/// worker's own are already; this catches those it inherited without the flag (a supervisor's pipe, a socket passed
/// to it), which the watchdog would otherwise keep open after the worker's death. `close_range(2)` with
/// `CLOSE_RANGE_CLOEXEC` (Linux 5.11), else one by one; only async-signal-safe system calls, no allocation.
fn cloexec_above_stdio() -> std::io::Result<()> {
    const CLOSE_RANGE_CLOEXEC: libc::c_uint = 1 << 2;
    // SAFETY: changes only descriptor flags of this (forked) process; touches no memory.
    #[allow(unsafe_code)]
    let r = unsafe {
        libc::syscall(
            libc::SYS_close_range,
            3 as libc::c_uint,
            libc::c_uint::MAX,
            CLOSE_RANGE_CLOEXEC,
        )
    };
    if r != 0 {
        for fd in 3..65_536 {
            // SAFETY: as above; EBADF on unused numbers is ignored.
            #[allow(unsafe_code)]
            unsafe {
                libc::fcntl(fd, libc::F_SETFD, libc::FD_CLOEXEC)
            };
        }
    }
    Ok(())
}

/// A close-on-exec pipe (read end, write end): only the watchdog, given the read end as its standard input, holds
/// a copy after `exec`.
fn pipe() -> std::io::Result<(OwnedFd, OwnedFd)> {
    nix::unistd::pipe2(nix::fcntl::OFlag::O_CLOEXEC).map_err(std::io::Error::from)
}

/// Removes what dead workers of this machine left ([module](self)): containers labelled [`LABEL`] (when `docker`
/// says so; errors leave them) and `vb-planner-*` directories in the temporary directory.
pub async fn sweep(docker: bool) -> Swept {
    let Ok(me) = Owner::current() else {
        return Swept::default();
    };
    let mut swept = Swept::default();
    if docker {
        swept.containers = sweep_containers(me).await;
    }
    for entry in std::fs::read_dir(std::env::temp_dir())
        .into_iter()
        .flatten()
        .flatten()
    {
        let name = entry.file_name().to_string_lossy().into_owned();
        let dead = dir_owner(&name).is_some_and(|o| o.fate(me, true) == Fate::Dead);
        if dead && std::fs::remove_dir_all(entry.path()).is_ok() {
            swept.dirs += 1;
        }
    }
    swept
}

async fn sweep_containers(me: &Owner) -> usize {
    let listed = tokio::process::Command::new("docker")
        .args(["ps", "--all", "--no-trunc", "--filter"])
        .arg(format!("label={LABEL}"))
        .args([
            "--format",
            &format!("{{{{.ID}}}} {{{{.Label \"{LABEL}\"}}}}"),
        ])
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .output();
    let Ok(Ok(out)) = tokio::time::timeout(std::time::Duration::from_secs(30), listed).await else {
        return 0;
    };
    if !out.status.success() {
        return 0;
    }
    let dead: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_once(' '))
        .filter(|(id, owner)| {
            !id.is_empty()
                && id.bytes().all(|b| b.is_ascii_hexdigit())
                && Owner::parse(owner).is_some_and(|o| o.fate(me, false) == Fate::Dead)
        })
        .map(|(id, _)| id.to_string())
        .collect();
    if dead.is_empty() {
        return 0;
    }
    let removed = tokio::process::Command::new("docker")
        .args(["rm", "--force"])
        .args(&dead)
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .output();
    match tokio::time::timeout(std::time::Duration::from_secs(60), removed).await {
        Ok(Ok(out)) => String::from_utf8_lossy(&out.stdout).lines().count(),
        _ => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_and_directory_names_name_their_owner() {
        let me = Owner::current().expect("this process");
        assert_eq!(Owner::parse(&me.label()).as_ref(), Some(me));
        let path = private_dir_path().expect("a path");
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let owner = dir_owner(&name).expect("an owner");
        assert_eq!(owner.fate(me, true), Fate::Alive);
        if std::env::temp_dir() == Path::new("/tmp") {
            // A Unix socket's path has at most 107 bytes.
            assert!(
                path.join("planner.sock").as_os_str().len() < 108,
                "{}",
                path.display()
            );
        }
        for bad in ["", "a.1.2", "zz.1.2.3", "ab.1.2.3.4", "ab.x.2.3", "ab..2.3"] {
            assert_eq!(Owner::parse(bad), None, "{bad}");
        }
        assert_eq!(
            dir_owner("vb-planner-0123456789abcdef"),
            None,
            "an old name"
        );
    }

    #[test]
    fn only_provably_dead_owners_are_dead() {
        let me = Owner::current().expect("this process").clone();
        assert_eq!(me.fate(&me, false), Fate::Alive);
        // This process id with another start time: an earlier process that had the id.
        let earlier = Owner {
            start: me.start + 1,
            ..me.clone()
        };
        assert_eq!(earlier.fate(&me, false), Fate::Dead);
        // A process that exited.
        let mut child = Command::new("true").spawn().expect("true");
        let pid = child.id();
        child.wait().expect("wait");
        let gone = Owner { pid, ..me.clone() };
        assert_eq!(gone.fate(&me, false), Fate::Dead);
        // The parent of this test, alive, with its real start time; with a wrong one.
        let parent = std::os::unix::process::parent_id();
        let start = start_time(&parent.to_string()).expect("the parent's start time");
        let alive = Owner {
            pid: parent,
            start,
            ..me.clone()
        };
        assert_eq!(alive.fate(&me, false), Fate::Alive);
        // Another PID namespace, or another machine sharing the Docker daemon: never provably dead.
        let other_ns = Owner {
            pidns: me.pidns + 1,
            ..earlier.clone()
        };
        assert_eq!(other_ns.fate(&me, true), Fate::Unknown);
        let other_boot = Owner {
            boot: "0".repeat(32),
            ..earlier.clone()
        };
        assert_eq!(other_boot.fate(&me, false), Fate::Unknown);
        // A directory of this machine's temporary directory made before this boot: its worker is dead.
        assert_eq!(other_boot.fate(&me, true), Fate::Dead);
    }

    #[test]
    fn a_watchdog_removes_the_directory_when_its_pipe_closes() {
        let dir = private_dir_path().expect("a path");
        let mut dog = Watchdog::spawn("vb-planner-no-such-container", &dir).expect("a watchdog");
        std::fs::create_dir(&dir).expect("the directory");
        std::fs::write(dir.join("file"), "x").expect("a file");
        std::thread::sleep(std::time::Duration::from_millis(300));
        assert!(dir.exists(), "removed while the worker holds the pipe");
        dog.client_exited();
        drop(dog);
        let t0 = std::time::Instant::now();
        while dir.exists() && t0.elapsed() < std::time::Duration::from_secs(20) {
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        assert!(!dir.exists(), "{} stays", dir.display());
    }

    #[tokio::test]
    async fn a_sweep_removes_the_directories_of_dead_owners_only() {
        let me = Owner::current().expect("this process");
        let mut child = Command::new("true").spawn().expect("true");
        let pid = child.id();
        child.wait().expect("wait");
        let dead = Owner { pid, ..me.clone() };
        let tmp = std::env::temp_dir();
        let dead_dir = tmp.join(format!("{DIR_PREFIX}{}-0a", dead.dir_tag()));
        let live_dir = tmp.join(format!("{DIR_PREFIX}{}-0b", me.dir_tag()));
        for d in [&dead_dir, &live_dir] {
            std::fs::create_dir_all(d.join("sub")).expect("a directory");
        }
        let swept = sweep(false).await;
        let (dead_stays, live_stays) = (dead_dir.exists(), live_dir.exists());
        let _ = std::fs::remove_dir_all(&dead_dir);
        let _ = std::fs::remove_dir_all(&live_dir);
        assert!(swept.dirs >= 1, "{swept:?}");
        assert!(!dead_stays && live_stays);
    }
}
