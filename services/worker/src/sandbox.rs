//! Resource limits of `exec` planner processes, applied in the forked child before it executes the planner, and
//! the kill that follows the worker's death: `PR_SET_PDEATHSIG` makes the kernel send SIGKILL to the planner when
//! the worker thread that started it dies (a worker killed with SIGKILL included), so no planner outlives its worker.

use nix::sys::resource::{setrlimit, Resource};

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
    /// Applies the limits and the parent-death signal to the calling process. Runs in the forked child before
    /// `exec`: it makes only the async-signal-safe system calls `setrlimit` and `prctl` and allocates nothing.
    pub fn apply_in_child(&self) -> std::io::Result<()> {
        let set = |r: Resource, v: u64| setrlimit(r, v, v).map_err(std::io::Error::from);
        set(Resource::RLIMIT_AS, self.address_space)?;
        set(Resource::RLIMIT_CPU, self.cpu_seconds)?;
        set(Resource::RLIMIT_NOFILE, self.open_files)?;
        set(Resource::RLIMIT_FSIZE, self.file_size)?;
        set(Resource::RLIMIT_NPROC, self.processes)?;
        nix::sys::prctl::set_pdeathsig(nix::sys::signal::Signal::SIGKILL)
            .map_err(std::io::Error::from)
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
