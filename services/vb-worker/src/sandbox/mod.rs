//! Containment of `exec` planner processes, applied in the forked child before it executes the planner: resource
//! limits, the kill that follows the worker's death (`PR_SET_PDEATHSIG` makes the kernel send SIGKILL to the
//! planner when the worker thread that started it dies, a worker killed with SIGKILL included), an optional
//! unprivileged user, and namespaces of its own ([`namespaces`]) so that nothing it starts outlives it and it sees no
//! other process. [`Containment::probe`] tells at start whether this machine allows the namespaces.

use nix::sys::resource::{setrlimit, Resource};

pub mod hidden;
pub mod namespaces;
pub mod reaper;

/// How exec planners are contained: always the resource limits and the death signal; the namespaces where the
/// machine allows them (a worker refuses exec planners where it does not, see [`Containment::probe`]); optionally
/// another user.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Containment {
    /// Run the planner in PID, mount and IPC namespaces of its own ([`namespaces`]).
    pub namespaces: bool,
    /// Run the planner as this (unprivileged) user.
    pub user: Option<PlannerUser>,
}

impl Containment {
    /// Full containment (namespaces) if this machine allows it: starts `true` in the namespaces and reports why not
    /// when that fails (no privilege to unshare or mount: an unprivileged container without user namespaces, a
    /// kernel without them).
    pub async fn probe(user: Option<PlannerUser>) -> Result<Containment, String> {
        let c = Containment {
            namespaces: true,
            user,
        };
        let ns = namespaces::Namespaces::new(user.map(|u| (u.uid, u.gid)), &[]);
        let limits = Limits::default();
        let mut cmd = tokio::process::Command::new("/bin/sh");
        cmd.args(["-c", "test -d /proc/1 && test ! -e /proc/2 && test -w /tmp"])
            .env_clear()
            .current_dir("/")
            .process_group(0)
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .kill_on_drop(true);
        // SAFETY: as for every planner (`crate::exec::start`): only async-signal-safe calls on prepared memory.
        #[allow(unsafe_code)]
        unsafe {
            cmd.pre_exec(move || c.apply_in_child(&limits, &ns));
        }
        let why = |e: String| format!("planners cannot be given namespaces of their own here: {e}");
        let mut child = cmd.spawn().map_err(|e| why(e.to_string()))?;
        match tokio::time::timeout(std::time::Duration::from_secs(10), child.wait()).await {
            Ok(Ok(s)) if s.success() => Ok(c),
            Ok(Ok(s)) => Err(why(format!(
                "a test process in them did not see a private /proc and a writable /tmp ({s})"
            ))),
            Ok(Err(e)) => Err(why(e.to_string())),
            Err(_) => Err(why(
                "a test process in them did not finish within 10 s".into()
            )),
        }
    }

    /// Everything the forked child does before `exec`, in order: resource limits and the death signal, the
    /// namespaces (the child then is the planner, PID 1 of its namespace, with a private `/proc` and temporary
    /// directories, the worker's secrets covered: [`hidden`]), the user, and then no capability left. Only async-signal-safe system calls on memory prepared before the fork.
    pub fn apply_in_child(
        &self,
        limits: &Limits,
        ns: &namespaces::Namespaces,
    ) -> std::io::Result<()> {
        limits.apply_in_child()?;
        namespaces::die_with_parent(Some(ns.worker()))?;
        if self.namespaces {
            ns.enter_in_child()?;
        }
        if let Some(u) = &self.user {
            u.become_in_child()?;
        }
        if self.namespaces {
            hidden::drop_capabilities()?;
        }
        Ok(())
    }
}

/// Limits of one planner process (and, for the per-process ones, each of its children).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Address space, bytes (virtual memory: a Python planner with a deep-learning framework maps several GB).
    pub address_space: u64,
    /// CPU time, s.
    pub cpu_seconds: u64,
    /// Open file descriptors.
    pub open_files: u64,
    /// Size of any file it writes, bytes.
    pub file_size: u64,
    /// Processes of its user (not enforced for root).
    pub processes: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            address_space: 16 << 30,
            cpu_seconds: 3600,
            open_files: 1024,
            file_size: 1 << 30,
            processes: 4096,
        }
    }
}

impl Limits {
    /// Applies the limits to the calling process. Runs in the forked child before
    /// `exec`: it makes only the async-signal-safe system calls `setrlimit` and `prctl` and allocates nothing.
    pub fn apply_in_child(&self) -> std::io::Result<()> {
        let set = |r: Resource, v: u64| setrlimit(r, v, v).map_err(std::io::Error::from);
        set(Resource::RLIMIT_AS, self.address_space)?;
        set(Resource::RLIMIT_CPU, self.cpu_seconds)?;
        set(Resource::RLIMIT_NOFILE, self.open_files)?;
        set(Resource::RLIMIT_FSIZE, self.file_size)?;
        set(Resource::RLIMIT_NPROC, self.processes)
    }
}

/// An unprivileged user to run exec planners as (`vb worker --planner-user NAME`): the planner cannot read the
/// worker's files or signal its processes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlannerUser {
    pub uid: u32,
    pub gid: u32,
}

impl PlannerUser {
    /// The user named `name` in the system's user database.
    pub fn lookup(name: &str) -> Result<PlannerUser, String> {
        match nix::unistd::User::from_name(name) {
            Ok(Some(u)) => Ok(PlannerUser {
                uid: u.uid.as_raw(),
                gid: u.gid.as_raw(),
            }),
            Ok(None) => Err(format!("no user `{name}` on this machine")),
            Err(e) => Err(format!("looking up user `{name}`: {e}")),
        }
    }

    /// Drops to this user (supplementary groups, group, then user). Runs in the forked child before `exec`: only
    /// async-signal-safe system calls, no allocation.
    pub fn become_in_child(&self) -> std::io::Result<()> {
        use nix::unistd::{setgid, setgroups, setuid, Gid, Uid};
        let gid = Gid::from_raw(self.gid);
        setgroups(&[gid]).map_err(std::io::Error::from)?;
        setgid(gid).map_err(std::io::Error::from)?;
        setuid(Uid::from_raw(self.uid)).map_err(std::io::Error::from)
    }
}
