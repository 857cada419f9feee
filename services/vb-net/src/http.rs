//! An axum router served over HTTP/1.1 within [`Limits`].
//!
//! A request's head must arrive within [`Limits::header_timeout`] of the connection's start or of the previous
//! response (hyper's header-read timeout: a kept-alive connection waiting for its next request is closed after it
//! too), a head is at most [`MAX_HEAD`] bytes, and a connection that moves no bytes for [`Limits::idle_timeout`]
//! (a stalled body, a client that does not read its response) is closed.

use crate::{Incoming, Limits};
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;

/// Largest request head (request line and headers) read, bytes.
pub const MAX_HEAD: usize = 64 * 1024;

/// Serves `router` on `listener` until the future is dropped (connections being served finish on their own).
pub async fn serve(
    listener: TcpListener,
    router: axum::Router,
    limits: &Limits,
    name: &'static str,
) -> std::io::Result<()> {
    let mut incoming = Incoming::new(listener, limits, name);
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(limits.header_timeout)
        .max_buf_size(MAX_HEAD)
        .keep_alive(true);
    loop {
        let conn = incoming.accept().await;
        let svc = Marked {
            state: conn.state.clone(),
            inner: TowerToHyperService::new(router.clone()),
        };
        let served = http.serve_connection(TokioIo::new(conn), svc);
        tokio::spawn(async move {
            if let Err(e) = served.await {
                tracing::debug!(error = %e, "connection ended with an error");
            }
        });
    }
}

/// The router's service, marking on its connection that a request arrived (a full server sheds only connections
/// that have not sent one).
struct Marked {
    state: std::sync::Arc<crate::registry::ConnState>,
    inner: TowerToHyperService<axum::Router>,
}

impl<B> hyper::service::Service<hyper::Request<B>> for Marked
where
    TowerToHyperService<axum::Router>: hyper::service::Service<hyper::Request<B>>,
{
    type Response =
        <TowerToHyperService<axum::Router> as hyper::service::Service<hyper::Request<B>>>::Response;
    type Error =
        <TowerToHyperService<axum::Router> as hyper::service::Service<hyper::Request<B>>>::Error;
    type Future =
        <TowerToHyperService<axum::Router> as hyper::service::Service<hyper::Request<B>>>::Future;

    fn call(&self, req: hyper::Request<B>) -> Self::Future {
        self.state.mark_request();
        self.inner.call(req)
    }
}
