//! [`Conn`]: an accepted TCP connection with its slot, its idle timeout and, where asked, a first-request deadline.

use crate::registry::{ConnState, Slot};
use std::future::Future;
use std::io;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::TcpStream;
use tokio::time::{Instant, Sleep};

/// An accepted connection. It holds its place in its server's registry until it is dropped. Once its deadline
/// has passed, its reads and writes fail (with [`io::ErrorKind::ConnectionAborted`]), so the protocol on top ends the
/// connection (and drops it, closing the socket). The deadline is the last read or write that moved bytes plus the
/// idle timeout and, until its first request is marked, its start plus the first-request timeout; a connection the
/// server sheds for a new one (it had sent no request when the server was full) fails at once.
#[derive(Debug)]
pub struct Conn {
    io: TcpStream,
    remote: Option<SocketAddr>,
    _slot: Slot,
    pub(crate) state: Arc<ConnState>,
    idle: Duration,
    last_progress: Instant,
    first_request_by: Option<Instant>,
    timer: Pin<Box<Sleep>>,
    timer_at: Instant,
    /// Why the deadline passed, once it has (every later read and write fails the same way).
    expired: Option<&'static str>,
}

impl Conn {
    pub(crate) fn new(
        io: TcpStream,
        slot: Slot,
        idle: Duration,
        first_request: Option<Duration>,
    ) -> Conn {
        let now = Instant::now();
        let remote = io.peer_addr().ok();
        let timer_at = now + idle;
        Conn {
            io,
            remote,
            state: slot.state.clone(),
            _slot: slot,
            idle,
            last_progress: now,
            first_request_by: first_request.map(|d| now + d),
            timer: Box::pin(tokio::time::sleep_until(timer_at)),
            timer_at,
            expired: None,
        }
    }

    /// The peer's address, when the socket could tell.
    pub fn remote_addr(&self) -> Option<SocketAddr> {
        self.remote
    }

    fn progress(&mut self) {
        self.last_progress = Instant::now();
    }

    /// The error to fail a pending read or write with, if the deadline has passed; otherwise arranges to be woken
    /// at the deadline.
    fn check_deadline(&mut self, cx: &mut Context<'_>) -> Option<io::Error> {
        if self.expired.is_none() {
            let mut deadline = self.last_progress + self.idle;
            let mut why = "connection idle for too long";
            if let Some(by) = self.first_request_by {
                if self.state.requested() {
                    self.first_request_by = None;
                } else if by < deadline {
                    deadline = by;
                    why = "no request within the header timeout";
                }
            }
            if self.state.is_shed() {
                self.expired = Some("shed for a new connection: the server is full");
            } else if Instant::now() >= deadline {
                self.expired = Some(why);
            } else {
                // Only a connection without a request can be shed, so only it needs waking for that.
                if !self.state.requested() {
                    self.state.park(cx.waker());
                }
                if self.timer_at != deadline {
                    self.timer.as_mut().reset(deadline);
                    self.timer_at = deadline;
                }
                if self.timer.as_mut().poll(cx).is_ready() {
                    self.expired = Some(why);
                }
            }
            if let Some(why) = self.expired {
                tracing::debug!(peer = ?self.remote, why, "closing a connection past its deadline");
            }
        }
        self.expired_error()
    }

    /// `ConnectionAborted`, not `TimedOut`: tonic's TLS accept loop skips a handshake that failed with the former
    /// and ends (stops serving) on the latter ([`tame`]).
    fn expired_error(&self) -> Option<io::Error> {
        self.expired
            .map(|why| io::Error::new(io::ErrorKind::ConnectionAborted, why))
    }
}

/// A socket error as one that tonic's TLS accept loop skips. That loop (tonic 0.12) goes on after a failed handshake
/// only for a few error kinds (reset, aborted, broken pipe, invalid data, early EOF) and stops accepting for good on
/// any other: a peer whose handshake ended in `ETIMEDOUT` or `EHOSTUNREACH` would take the whole server down.
fn tame(e: io::Error) -> io::Error {
    use io::ErrorKind::*;
    match e.kind() {
        ConnectionAborted | ConnectionReset | BrokenPipe | Interrupted | InvalidData
        | UnexpectedEof | WouldBlock => e,
        _ => io::Error::new(ConnectionAborted, e),
    }
}

impl AsyncRead for Conn {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        if let Some(e) = self.expired_error() {
            return Poll::Ready(Err(e));
        }
        let before = buf.filled().len();
        match Pin::new(&mut self.io).poll_read(cx, buf) {
            Poll::Ready(Ok(())) => {
                if buf.filled().len() > before {
                    self.progress();
                }
                Poll::Ready(Ok(()))
            }
            Poll::Ready(Err(e)) => Poll::Ready(Err(tame(e))),
            Poll::Pending => match self.check_deadline(cx) {
                Some(e) => Poll::Ready(Err(e)),
                None => Poll::Pending,
            },
        }
    }
}

impl Conn {
    /// A write's outcome as the guard sees it: bytes written are progress, errors are [`tame`]d, and a write that
    /// waits is checked against the deadline.
    fn after_write(
        &mut self,
        cx: &mut Context<'_>,
        r: Poll<io::Result<usize>>,
    ) -> Poll<io::Result<usize>> {
        match r {
            Poll::Ready(Ok(n)) => {
                if n > 0 {
                    self.progress();
                }
                Poll::Ready(Ok(n))
            }
            Poll::Ready(Err(e)) => Poll::Ready(Err(tame(e))),
            Poll::Pending => match self.check_deadline(cx) {
                Some(e) => Poll::Ready(Err(e)),
                None => Poll::Pending,
            },
        }
    }
}

impl AsyncWrite for Conn {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        if let Some(e) = self.expired_error() {
            return Poll::Ready(Err(e));
        }
        let r = Pin::new(&mut self.io).poll_write(cx, buf);
        self.after_write(cx, r)
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[io::IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        if let Some(e) = self.expired_error() {
            return Poll::Ready(Err(e));
        }
        let r = Pin::new(&mut self.io).poll_write_vectored(cx, bufs);
        self.after_write(cx, r)
    }

    fn is_write_vectored(&self) -> bool {
        self.io.is_write_vectored()
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.io).poll_flush(cx).map_err(tame)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.io).poll_shutdown(cx).map_err(tame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_that_would_stop_tonics_tls_accept_loop_become_aborted_connections() {
        for kind in [
            io::ErrorKind::TimedOut,
            io::ErrorKind::HostUnreachable,
            io::ErrorKind::NetworkUnreachable,
            io::ErrorKind::Other,
        ] {
            let e = tame(io::Error::new(kind, "x"));
            assert_eq!(e.kind(), io::ErrorKind::ConnectionAborted, "{kind:?}");
            assert!(e.to_string().contains('x'));
        }
        let e = tame(io::Error::new(io::ErrorKind::ConnectionReset, "reset"));
        assert_eq!(e.kind(), io::ErrorKind::ConnectionReset);
    }
}
