//! tonic servers within [`Limits`]: build the server with [`server`], add services, and serve it on [`incoming`].
//!
//! A new connection must send its first request within [`Limits::header_timeout`] (a TLS handshake, the HTTP/2
//! preface and a request's headers: [`FirstRequest`] marks it), an established one is pinged every
//! [`Limits::keepalive_interval`] and dropped when the peer does not answer within [`Limits::keepalive_timeout`]
//! (so a worker's or a progress stream's quiet connection stays and a dead peer's goes), and one that moves no
//! bytes for [`Limits::idle_timeout`] is closed.

use crate::registry::ConnState;
use crate::{Conn, Incoming, Limits};
use std::net::SocketAddr;
use std::sync::Arc;
use tokio::net::TcpListener;

/// The layer [`server`] puts around every service.
pub type Layer = tower_layer::Stack<
    tonic::service::interceptor::InterceptorLayer<FirstRequest>,
    tower_layer::Identity,
>;
/// A server of [`server`] with its services.
pub type Router = tonic::transport::server::Router<Layer>;

/// A tonic server with HTTP/2 keepalive pings and the first-request mark (add TLS and services to it).
pub fn server(limits: &Limits) -> tonic::transport::Server<Layer> {
    tonic::transport::Server::builder()
        .http2_keepalive_interval(Some(limits.keepalive_interval))
        .http2_keepalive_timeout(Some(limits.keepalive_timeout))
        .layer(tonic::service::interceptor(FirstRequest))
}

/// The connections of `listener` within `limits`, for `Router::serve_with_incoming`.
pub fn incoming(listener: TcpListener, limits: &Limits, name: &'static str) -> Incoming {
    Incoming::new(listener, limits, name).with_first_request_deadline()
}

/// What a request learns of its connection (in its extensions, also under TLS).
#[derive(Clone, Debug)]
pub struct ConnInfo {
    /// The peer's address.
    pub remote: Option<SocketAddr>,
    state: Arc<ConnState>,
}

impl tonic::transport::server::Connected for Conn {
    type ConnectInfo = ConnInfo;

    fn connect_info(&self) -> ConnInfo {
        ConnInfo {
            remote: self.remote_addr(),
            state: self.state.clone(),
        }
    }
}

/// Marks that its connection's first request has arrived, which lifts the first-request deadline.
#[derive(Clone, Copy, Debug, Default)]
pub struct FirstRequest;

impl tonic::service::Interceptor for FirstRequest {
    fn call(&mut self, req: tonic::Request<()>) -> Result<tonic::Request<()>, tonic::Status> {
        if let Some(info) = req.extensions().get::<ConnInfo>() {
            info.state.mark_request();
        }
        Ok(req)
    }
}
