//! What both command-line programs (`vb`, `vb-submit`) do around their work: die quietly on a closed pipe like other
//! Unix tools, and report an error as one clear message (its causes after colons), never as a backtrace.

use std::fmt::Display;
use std::process::ExitCode;

/// Restores the default action of SIGPIPE (the Rust runtime ignores it, so printing into a closed pipe, as in
/// `vb-submit status | head -1`, panicked): the process now ends quietly, as `cat` or `ls` do.
pub fn restore_sigpipe() {
    use nix::sys::signal::{signal, SigHandler, Signal};
    // SAFETY: called at the start of `main`, before any other thread exists; SIG_DFL installs no handler code.
    #[allow(unsafe_code)]
    let _ = unsafe { signal(Signal::SIGPIPE, SigHandler::SigDfl) };
}

/// Writes `text` to standard output. A closed pipe (`vb-submit status | head -1`) ends the process quietly with
/// success, as `head`'s readers expect; SIGPIPE itself stays ignored, so a socket that closes mid-write fails its
/// call with an error that says so instead of killing the process without a word.
pub fn out(text: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout.write_fmt(text).and_then(|()| stdout.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: writing to standard output: {e}");
        std::process::exit(1);
    }
}

/// The exit code of a run, printing an error as `error: message: cause: cause` on stderr (with `RUST_BACKTRACE` set
/// too: a user's mistake is not a crash).
pub fn exit_code<E: Display>(result: Result<(), E>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
