//! The worker's own secrets, kept from the planners it starts. A planner runs as the worker's user unless the worker
//! is given `--planner-user`, so its permissions alone would let it read the worker's token file. In the planner's
//! mount namespace each file registered here ([`hide_from_planners`]) is covered with an empty one (`/dev/null`
//! bound over it), and before the planner executes it loses every capability (bounding, permitted, effective,
//! inheritable and ambient sets, with `no_new_privs`), so it can neither unmount the cover nor mount anything, as
//! root of the worker's machine or of its own user namespace alike.

use nix::errno::Errno;
use std::ffi::{CStr, CString};
use std::io;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

static HIDDEN: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Registers files no planner of this process may read (the worker's token file, a store's database, the user's
/// submission token). Files that do not exist are skipped; each path is taken as it resolves now.
pub fn hide_from_planners<P: AsRef<Path>>(paths: impl IntoIterator<Item = P>) {
    let mut hidden = HIDDEN.lock().unwrap_or_else(|p| p.into_inner());
    for p in paths {
        if let Ok(real) = std::fs::canonicalize(p.as_ref()) {
            if real.is_file() && !hidden.contains(&real) {
                hidden.push(real);
            }
        }
    }
}

/// The registered files, for the child to cover (prepared before the fork: the child may not allocate).
pub(crate) fn targets() -> Vec<CString> {
    use std::os::unix::ffi::OsStrExt;
    let hidden = HIDDEN.lock().unwrap_or_else(|p| p.into_inner());
    hidden
        .iter()
        .filter_map(|p| CString::new(p.as_os_str().as_bytes()).ok())
        .collect()
}

/// In the child's mount namespace: binds `/dev/null` over each target (one that has gone since is skipped).
pub(crate) fn cover(targets: &[CString]) -> io::Result<()> {
    use nix::mount::{mount, MsFlags};
    let none: Option<&CStr> = None;
    for t in targets {
        match mount(
            Some(c"/dev/null"),
            t.as_c_str(),
            none,
            MsFlags::MS_BIND,
            none,
        ) {
            Ok(()) | Err(Errno::ENOENT) => {}
            Err(e) => return Err(io::Error::from_raw_os_error(e as i32)),
        }
    }
    Ok(())
}

/// In the planner, the last step before it executes: no capability left, now or after `exec` (as root too).
pub(crate) fn drop_capabilities() -> io::Result<()> {
    // SAFETY: prctl and capset with integers and stack memory only: async-signal-safe, no allocation.
    #[allow(unsafe_code)]
    unsafe {
        // The bounding set first (needs CAP_SETPCAP, which is about to go); past the kernel's last capability the
        // call fails with EINVAL, and without CAP_SETPCAP (a planner user already) with EPERM: nothing to drop.
        for cap in 0..64 {
            if libc::prctl(libc::PR_CAPBSET_DROP, cap, 0, 0, 0) != 0 {
                break;
            }
        }
        libc::prctl(
            libc::PR_CAP_AMBIENT,
            libc::PR_CAP_AMBIENT_CLEAR_ALL,
            0,
            0,
            0,
        );
        #[repr(C)]
        struct Header {
            version: u32,
            pid: i32,
        }
        #[repr(C)]
        #[derive(Clone, Copy)]
        struct Data {
            effective: u32,
            permitted: u32,
            inheritable: u32,
        }
        let header = Header {
            version: 0x2008_0522, // _LINUX_CAPABILITY_VERSION_3
            pid: 0,
        };
        let data = [Data {
            effective: 0,
            permitted: 0,
            inheritable: 0,
        }; 2];
        if libc::syscall(libc::SYS_capset, &header, data.as_ptr()) != 0 {
            return Err(io::Error::last_os_error());
        }
        if libc::prctl(libc::PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(())
}
