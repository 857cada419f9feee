//! Isolation of an exec planner in namespaces of its own, so the planner and everything it starts live and die
//! together and see nothing of the machine's other processes or temporary files:
//!
//! - a **PID namespace**: the planner is its PID 1, so when it dies (or is killed) the kernel kills every process
//!   it started, `setsid` or double-forked ones included, and it cannot see or signal processes outside;
//! - a **mount namespace** with its own `/proc` (only the namespace's processes: no other command line or
//!   environment to read), and fresh tmpfs mounts on `/tmp` (its home and working directory), `/var/tmp`,
//!   `/dev/shm` and `/run/lock`, which vanish with the namespace: nothing it writes there outlives it or is seen
//!   by another planner. Files its command names in those directories (a script in `/tmp/...`) stay visible to
//!   it, read-only, at the same path ([`Visible`]);
//! - an **IPC namespace** (System V and POSIX message queues of its own);
//! - the worker's secrets (its token file) covered with an empty file, and no capability to uncover them
//!   ([`super::hidden`]).
//!
//! The worker's child (the *keeper*) unshares the namespaces and forks the planner into them; the keeper stays in the
//! worker's process group, waits for the planner and exits with its status. Both carry `PR_SET_PDEATHSIG`: the
//! worker's death kills the keeper, the keeper's death kills the planner, the planner's death kills its namespace.
//! A root worker enters the namespaces directly; another user enters them through a user namespace in which it is
//! root (so it may mount), mapped onto its own uid. Everything here runs between `fork` and `exec` and therefore
//! makes only async-signal-safe system calls on memory prepared before the fork.

use nix::errno::Errno;
use nix::mount::{mount, MsFlags};
use nix::sched::{unshare, CloneFlags};
use nix::sys::signal::Signal;
use nix::sys::wait::{waitpid, WaitStatus};
use nix::unistd::{fork, ForkResult, Pid};
use std::ffi::{CStr, CString};
use std::io;
use std::os::fd::{AsRawFd, OwnedFd};
use std::path::{Path, PathBuf};

/// Size of the planner's `/tmp` (its working directory); the other temporary mounts get [`SMALL_TMPFS`].
pub const TMP_SIZE: &str = "1g";
const SMALL_TMPFS: &str = "64m";

/// Temporary directories that get a fresh tmpfs when they exist, besides `/tmp`.
const OTHER_TMP: [&CStr; 3] = [c"/var/tmp", c"/dev/shm", c"/run/lock"];

/// The directories whose host contents a planner does not see.
const PRIVATE_ROOTS: [&str; 3] = ["/tmp", "/var/tmp", "/dev/shm"];

/// The first descriptor number the child parks [`Visible`] files at (below the planner's 1024-descriptor limit).
const FIRST_SLOT: usize = 900;
/// At most this many of them.
const MAX_VISIBLE: usize = 64;

/// A host file or directory in one of the [`PRIVATE_ROOTS`] that the planner's command names, bind-mounted
/// read-only at the same path in its namespace. The child opens it (`O_PATH`, at a fixed descriptor number) in its
/// new mount namespace before the private mounts hide it, and binds it from `/proc/self/fd/N` after them (a bind
/// mount's source must be in the caller's mount namespace, so the worker cannot open it for the child).
#[derive(Debug)]
struct Visible {
    target: CString,
    /// The descriptor number it is parked at, and `/proc/self/fd/N` of it.
    slot: i32,
    source: CString,
    /// The directories to make in the private tmpfs for the target, outermost first.
    parents: Vec<CString>,
    is_dir: bool,
}

impl Visible {
    /// What to keep visible for each absolute path under a private root that `argv` names, as an argument or as a
    /// word inside one (`sh -c "/tmp/env/bin/python -m planner"`, `VAR=/tmp/x`): the whole top-level directory
    /// below the root that holds it (`/tmp/env` for `/tmp/env/bin/python`: an interpreter's environment with its
    /// `pyvenv.cfg` and `lib/`, a build's target directory, a script's neighbours), or the file alone when it lies
    /// directly in the root.
    fn for_command(argv: &[String]) -> Vec<Visible> {
        kept(argv)
            .into_iter()
            .take(MAX_VISIBLE)
            .enumerate()
            .filter_map(|(i, (path, is_dir))| Visible::new(&path, is_dir, (FIRST_SLOT + i) as i32))
            .collect()
    }

    fn new(path: &std::path::Path, is_dir: bool, slot: i32) -> Option<Visible> {
        use std::os::unix::ffi::OsStrExt;
        let source = CString::new(format!("/proc/self/fd/{slot}")).ok()?;
        let target = CString::new(path.as_os_str().as_bytes()).ok()?;
        let root = PRIVATE_ROOTS.iter().find(|r| path.starts_with(r))?;
        let parents = path
            .ancestors()
            .skip(usize::from(!is_dir))
            .take_while(|a| a.as_os_str().len() > root.len())
            .filter_map(|a| CString::new(a.as_os_str().as_bytes()).ok())
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        Some(Visible {
            target,
            slot,
            source,
            parents,
            is_dir,
        })
    }

    /// In the child's new mount namespace, before the private mounts: holds the host's file at its slot.
    fn park(&self) -> io::Result<()> {
        use nix::fcntl::{open, OFlag};
        let mut flags = OFlag::O_PATH | OFlag::O_CLOEXEC;
        if self.is_dir {
            flags |= OFlag::O_DIRECTORY;
        }
        let fd = open(self.target.as_c_str(), flags, nix::sys::stat::Mode::empty())
            .map_err(|e| errno("opening a file of the command", e))?;
        // SAFETY: duplicating a descriptor this process owns onto a number it does not otherwise use.
        #[allow(unsafe_code)]
        let r = unsafe { libc::dup3(fd.as_raw_fd(), self.slot, libc::O_CLOEXEC) };
        if r < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    /// In the child, after the private mounts: makes the mount point and binds the host's file there, read-only.
    fn mount(&self) -> io::Result<()> {
        use nix::sys::stat::Mode;
        for dir in &self.parents {
            match nix::unistd::mkdir(dir.as_c_str(), Mode::from_bits_truncate(0o755)) {
                Ok(()) | Err(Errno::EEXIST) => {}
                Err(e) => return Err(errno("making a mount point", e)),
            }
        }
        if !self.is_dir {
            use nix::fcntl::OFlag;
            let flags = OFlag::O_CREAT | OFlag::O_WRONLY | OFlag::O_CLOEXEC;
            let fd = nix::fcntl::open(
                self.target.as_c_str(),
                flags,
                Mode::from_bits_truncate(0o644),
            )
            .map_err(|e| errno("making a mount point", e))?;
            drop(fd);
        }
        let none: Option<&CStr> = None;
        let source: &CStr = &self.source;
        let target: &CStr = &self.target;
        mount(
            Some(source),
            target,
            none,
            MsFlags::MS_BIND | MsFlags::MS_REC,
            none,
        )
        .map_err(|e| errno("binding a file of the command", e))?;
        let read_only = MsFlags::MS_BIND
            | MsFlags::MS_REMOUNT
            | MsFlags::MS_RDONLY
            | MsFlags::MS_NOSUID
            | MsFlags::MS_NODEV;
        mount(none, target, none, read_only, none).map_err(|e| errno("binding read-only", e))?;
        // SAFETY: closing the parked descriptor this process owns.
        #[allow(unsafe_code)]
        unsafe {
            libc::close(self.slot)
        };
        Ok(())
    }
}

/// Every absolute path under a private root named in `argv`: whole arguments, and the words of each argument split
/// at white space and shell punctuation.
fn command_paths(argv: &[String]) -> Vec<PathBuf> {
    let is_break = |c: char| c.is_whitespace() || ";&|()<>\"'`=:,".contains(c);
    let mut out = Vec::new();
    for arg in argv {
        for word in std::iter::once(arg.as_str()).chain(arg.split(is_break)) {
            let p = Path::new(word);
            if PRIVATE_ROOTS
                .iter()
                .any(|r| p.starts_with(r) && p != Path::new(r))
            {
                out.push(p.to_path_buf());
            }
        }
    }
    out
}

/// What keeping `p` visible takes: the top-level directory below its private root that holds it, or the file
/// itself directly in the root; nothing for a path that does not exist.
fn kept_for(p: &Path) -> Option<(PathBuf, bool)> {
    let root = PRIVATE_ROOTS.iter().find(|r| p.starts_with(r))?;
    let below = p.strip_prefix(root).ok()?;
    let first = below.components().next()?;
    let top = Path::new(root).join(first);
    let meta = std::fs::metadata(&top).ok()?;
    if !meta.is_dir() && top != p {
        return None;
    }
    std::fs::metadata(p).ok()?;
    Some((top, meta.is_dir()))
}

/// What stays visible for `argv`, sorted, once each: (path, whether a directory).
fn kept(argv: &[String]) -> Vec<(PathBuf, bool)> {
    let mut v: Vec<(PathBuf, bool)> = command_paths(argv)
        .iter()
        .filter_map(|p| kept_for(p))
        .collect();
    v.sort();
    v.dedup();
    v
}

/// The host's files a planner of `argv` still sees in its private temporary directories, for error messages.
pub fn visible_paths(argv: &[String]) -> Vec<PathBuf> {
    kept(argv).into_iter().map(|(p, _)| p).collect()
}

/// What the child needs, prepared before the fork (the child may not allocate).
#[derive(Debug)]
pub struct Namespaces {
    /// Options of `/tmp`'s tmpfs (its size, and its owner when the planner runs as another user).
    tmp_options: CString,
    other_options: CString,
    /// `/proc/self/uid_map` and `gid_map` lines when the namespaces are entered through a user namespace.
    user_maps: Option<(CString, CString)>,
    /// The worker's pid, to notice its death before `PR_SET_PDEATHSIG` was in place.
    worker: i32,
    /// Files of the command in the private directories.
    visible: Vec<Visible>,
    /// The worker's files covered in the planner's view ([`super::hidden`]).
    hidden: Vec<CString>,
}

impl Namespaces {
    /// The namespaces for a planner command `argv` that runs as `owner` (uid, gid), or as the worker's own user.
    pub fn new(owner: Option<(u32, u32)>, argv: &[String]) -> Namespaces {
        let uid = nix::unistd::geteuid().as_raw();
        let gid = nix::unistd::getegid().as_raw();
        let owner_opts = match owner {
            Some((u, g)) => format!(",mode=0700,uid={u},gid={g}"),
            None => ",mode=0700".to_string(),
        };
        let cstring = |s: String| CString::new(s).unwrap_or_default();
        Namespaces {
            tmp_options: cstring(format!("size={TMP_SIZE}{owner_opts}")),
            other_options: cstring(format!("size={SMALL_TMPFS},mode=1777")),
            user_maps: (uid != 0).then(|| {
                (
                    cstring(format!("0 {uid} 1\n")),
                    cstring(format!("0 {gid} 1\n")),
                )
            }),
            worker: std::process::id() as i32,
            visible: Visible::for_command(argv),
            hidden: super::hidden::targets(),
        }
    }

    /// The worker's process id (the parent the forked child checks it still has).
    pub fn worker(&self) -> i32 {
        self.worker
    }

    /// Enters the namespaces. Runs in the worker's forked child (after its resource limits, before it becomes the
    /// planner's user): returns in the planner, which then executes; the keeper never returns.
    pub fn enter_in_child(&self) -> io::Result<()> {
        let mut flags =
            CloneFlags::CLONE_NEWPID | CloneFlags::CLONE_NEWNS | CloneFlags::CLONE_NEWIPC;
        if self.user_maps.is_some() {
            flags |= CloneFlags::CLONE_NEWUSER;
        }
        unshare(flags).map_err(|e| errno("unshare", e))?;
        if let Some((uid_map, gid_map)) = &self.user_maps {
            write_file(c"/proc/self/setgroups", c"deny")?;
            write_file(c"/proc/self/uid_map", uid_map)?;
            write_file(c"/proc/self/gid_map", gid_map)?;
        }
        // The planner's end of this pipe tells it whether the keeper is still alive when its own death signal is
        // in place (no writer left: the keeper died before that).
        let (alive_r, alive_w) =
            nix::unistd::pipe2(nix::fcntl::OFlag::O_CLOEXEC | nix::fcntl::OFlag::O_NONBLOCK)
                .map_err(|e| errno("pipe2", e))?;
        // SAFETY: the worker's child is single-threaded here; both sides go on with async-signal-safe calls only.
        #[allow(unsafe_code)]
        match unsafe { fork() }.map_err(|e| errno("fork", e))? {
            ForkResult::Parent { child } => {
                drop(alive_r);
                keep(child, alive_w)
            }
            ForkResult::Child => {
                drop(alive_w);
                // Its parent, outside its PID namespace, reads as 0 whether alive or not: the pipe tells.
                die_with_parent(None)?;
                let mut byte = [0u8; 1];
                if nix::unistd::read(&alive_r, &mut byte) == Ok(0) {
                    // SAFETY: async-signal-safe; the process has nothing to flush.
                    #[allow(unsafe_code)]
                    unsafe {
                        libc::_exit(1)
                    };
                }
                drop(alive_r);
                self.mount_private()
            }
        }
    }

    /// The planner's view of the file system: its own `/proc` and temporary directories.
    fn mount_private(&self) -> io::Result<()> {
        let none: Option<&CStr> = None;
        mount(
            none,
            c"/",
            none,
            MsFlags::MS_REC | MsFlags::MS_PRIVATE,
            none,
        )
        .map_err(|e| errno("making / private", e))?;
        for v in &self.visible {
            v.park()?;
        }
        let hardened = MsFlags::MS_NOSUID | MsFlags::MS_NODEV;
        mount(
            Some(c"proc"),
            c"/proc",
            Some(c"proc"),
            hardened | MsFlags::MS_NOEXEC,
            none,
        )
        .map_err(|e| errno("mounting /proc", e))?;
        let tmp_options: &CStr = &self.tmp_options;
        mount(
            Some(c"tmpfs"),
            c"/tmp",
            Some(c"tmpfs"),
            hardened,
            Some(tmp_options),
        )
        .map_err(|e| errno("mounting /tmp", e))?;
        let other_options: &CStr = &self.other_options;
        for dir in OTHER_TMP {
            match mount(
                Some(c"tmpfs"),
                dir,
                Some(c"tmpfs"),
                hardened,
                Some(other_options),
            ) {
                Ok(()) | Err(Errno::ENOENT) | Err(Errno::ENOTDIR) => {}
                Err(e) => return Err(errno("mounting a private temporary directory", e)),
            }
        }
        for v in &self.visible {
            v.mount()?;
        }
        super::hidden::cover(&self.hidden)?;
        nix::unistd::chdir(c"/tmp").map_err(|e| errno("chdir /tmp", e))
    }
}

/// `PR_SET_PDEATHSIG` = SIGKILL, and the check that the parent (`parent`, when it can be seen) did not die before it
/// was set: the child of a dead parent has been handed to another, so its parent id changed.
pub(crate) fn die_with_parent(parent: Option<i32>) -> io::Result<()> {
    nix::sys::prctl::set_pdeathsig(Signal::SIGKILL).map_err(|e| errno("prctl", e))?;
    if parent.is_some_and(|p| nix::unistd::getppid().as_raw() != p) {
        // SAFETY: async-signal-safe.
        #[allow(unsafe_code)]
        unsafe {
            libc::_exit(1)
        };
    }
    Ok(())
}

/// The keeper: closes every descriptor but the standard ones and its end of the liveness pipe (it holds no copy of
/// the worker's sockets or of the exec-status pipe, so the worker sees the planner's `exec` at once), waits for the
/// planner and exits as it did.
fn keep(planner: Pid, alive: OwnedFd) -> ! {
    let keep_fd = alive.as_raw_fd() as libc::c_uint;
    close_range(3, keep_fd.saturating_sub(1));
    close_range(keep_fd + 1, libc::c_uint::MAX);
    let code = loop {
        match waitpid(planner, None) {
            Ok(WaitStatus::Exited(_, code)) => break code,
            Ok(WaitStatus::Signaled(_, sig, _)) => break 128 + sig as i32,
            Err(Errno::EINTR) | Ok(_) => continue,
            Err(_) => break 127,
        }
    };
    // SAFETY: async-signal-safe; the keeper has nothing to flush.
    #[allow(unsafe_code)]
    unsafe {
        libc::_exit(code)
    }
}

/// Closes descriptors `first..=last` (`close_range(2)`, or one by one on kernels before 5.9).
fn close_range(first: libc::c_uint, last: libc::c_uint) {
    if first > last {
        return;
    }
    // SAFETY: closing descriptors this process owns; no memory is touched.
    #[allow(unsafe_code)]
    let r = unsafe { libc::syscall(libc::SYS_close_range, first, last, 0) };
    if r != 0 {
        for fd in first..=last.min(65_535) {
            // SAFETY: as above; EBADF on unused numbers is ignored.
            #[allow(unsafe_code)]
            unsafe {
                libc::close(fd as libc::c_int)
            };
        }
    }
}

fn write_file(path: &CStr, text: &CStr) -> io::Result<()> {
    use nix::fcntl::{open, OFlag};
    use nix::sys::stat::Mode;
    let fd = open(path, OFlag::O_WRONLY | OFlag::O_CLOEXEC, Mode::empty())
        .map_err(|e| errno("opening a user-namespace map", e))?;
    nix::unistd::write(&fd, text.to_bytes())
        .map(|_| ())
        .map_err(|e| errno("writing a user-namespace map", e))
}

/// The error the spawn reports: only its errno crosses from the child to the worker (std sends that alone, and the
/// child may not allocate a message), so `_what` documents the step at the call.
fn errno(_what: &'static str, e: Errno) -> io::Error {
    io::Error::from_raw_os_error(e as i32)
}
