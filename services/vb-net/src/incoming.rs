//! [`Incoming`]: the accept loop of every server, with its connection limit.

use crate::registry::{Refusal, Registry};
use crate::{Conn, Limits};
use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::net::TcpListener;
use tokio::time::{Instant, Sleep};

/// How long the loop waits after an accept error that is not about one connection (out of descriptors or memory).
const BACKOFF: Duration = Duration::from_millis(100);
/// At most one warning per this about closed connections and accept errors (a flood must not flood the log).
const WARN_EVERY: Duration = Duration::from_secs(10);

/// The connections a listener accepts, as a stream that never ends and never fails: [`Conn`]s within the limits.
/// A connection beyond its peer address's share is closed at once; one accepted while [`Limits::max_connections`]
/// are open replaces the oldest that has sent no request, or is closed at once when all have.
pub struct Incoming {
    listener: TcpListener,
    registry: Arc<Registry>,
    limits: Limits,
    first_request: bool,
    name: &'static str,
    backoff: Option<Pin<Box<Sleep>>>,
    refused: u64,
    shed: u64,
    errors: u64,
    last_warning: Option<Instant>,
}

impl Incoming {
    /// Accepts on `listener` within `limits`; `name` says which server in log lines.
    pub fn new(listener: TcpListener, limits: &Limits, name: &'static str) -> Incoming {
        Incoming {
            listener,
            registry: Registry::new(limits.max_connections, limits.max_connections_per_peer),
            limits: *limits,
            first_request: false,
            name,
            backoff: None,
            refused: 0,
            shed: 0,
            errors: 0,
            last_warning: None,
        }
    }

    /// Also closes a connection whose first request has not arrived within [`Limits::header_timeout`] (for
    /// protocols whose server does not bound it itself: HTTP/2). Something must mark the request
    /// ([`crate::grpc`]'s interceptor does).
    pub fn with_first_request_deadline(mut self) -> Incoming {
        self.first_request = true;
        self
    }

    /// Connections open now.
    pub fn open(&self) -> usize {
        self.registry.open()
    }

    fn warn_now(&mut self) -> bool {
        let now = Instant::now();
        if self
            .last_warning
            .is_some_and(|t| now.duration_since(t) < WARN_EVERY)
        {
            return false;
        }
        self.last_warning = Some(now);
        true
    }

    /// The next connection within the limit.
    pub fn poll_accept(&mut self, cx: &mut Context<'_>) -> Poll<Conn> {
        loop {
            if let Some(b) = self.backoff.as_mut() {
                if b.as_mut().poll(cx).is_pending() {
                    return Poll::Pending;
                }
                self.backoff = None;
            }
            match self.listener.poll_accept(cx) {
                Poll::Pending => return Poll::Pending,
                Poll::Ready(Ok((io, addr))) => match self.registry.admit(Some(addr.ip())) {
                    Ok((slot, shed)) => {
                        self.shed += u64::from(shed);
                        if shed && self.warn_now() {
                            tracing::warn!(
                                server = self.name,
                                max_connections = self.limits.max_connections,
                                shed = self.shed,
                                "connection limit reached: closing the oldest connections that sent no request"
                            );
                            self.shed = 0;
                        }
                        let _ = io.set_nodelay(true);
                        let first = self.first_request.then_some(self.limits.header_timeout);
                        return Poll::Ready(Conn::new(io, slot, self.limits.idle_timeout, first));
                    }
                    Err(why) => {
                        // Dropping it closes it at once: no descriptor and no memory is kept for it.
                        drop(io);
                        self.refused += 1;
                        if self.warn_now() {
                            let what = match why {
                                Refusal::PeerShare => {
                                    "a peer address holds its share of connections"
                                }
                                Refusal::Full => {
                                    "connection limit reached and every connection is in use"
                                }
                            };
                            tracing::warn!(
                                server = self.name,
                                peer = %addr.ip(),
                                max_connections = self.limits.max_connections,
                                max_connections_per_peer = self.limits.max_connections_per_peer,
                                closed = self.refused,
                                "{what}: closing new connections"
                            );
                            self.refused = 0;
                        }
                    }
                },
                Poll::Ready(Err(e)) => {
                    // One connection's failure (aborted before accept) needs no pause; anything else (out of
                    // descriptors or memory) would fail again at once.
                    let transient = matches!(
                        e.kind(),
                        io::ErrorKind::ConnectionAborted
                            | io::ErrorKind::ConnectionReset
                            | io::ErrorKind::Interrupted
                            | io::ErrorKind::WouldBlock
                    );
                    if !transient {
                        self.errors += 1;
                        if self.warn_now() {
                            tracing::warn!(server = self.name, error = %e, errors = self.errors,
                                "accepting connections failed; retrying");
                            self.errors = 0;
                        }
                        self.backoff = Some(Box::pin(tokio::time::sleep(BACKOFF)));
                    }
                }
            }
        }
    }

    /// The next connection within the limit.
    pub async fn accept(&mut self) -> Conn {
        std::future::poll_fn(|cx| self.poll_accept(cx)).await
    }
}

impl tokio_stream::Stream for Incoming {
    type Item = io::Result<Conn>;

    fn poll_next(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<io::Result<Conn>>> {
        self.get_mut().poll_accept(cx).map(|c| Some(Ok(c)))
    }
}
