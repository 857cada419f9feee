//! Who may use the `Sim` API, and whose each episode is.
//!
//! - **Access**: with tokens configured ([`SimAccess::with_tokens`]: `vb worker --sim-token-file`, or
//!   `VB_SIM_TOKEN`), every call carries `authorization: Bearer <token>` with one of them; without, the API serves
//!   only clients on this machine (loopback addresses) and refuses every other peer.
//! - **Ownership**: an episode is its creator's, the pair (token, peer address): a call on an episode made by
//!   another client is answered as if the episode did not exist.
//! - **Expiry**: an episode that no call has touched for [`SimAccess::idle`] is closed, so a client that goes away
//!   gives its places back; each client holds at most [`PER_CLIENT`] of the server's episodes.

use sha2::{Digest, Sha256};
use std::net::IpAddr;
use std::time::Duration;
use tonic::{Request, Status};

/// Most episodes one client holds open at once (of [`crate::sim_service::MAX_EPISODES`]).
pub const PER_CLIENT: usize = 16;
/// How long an untouched episode stays open by default.
pub const DEFAULT_IDLE: Duration = Duration::from_secs(600);

/// The API's access rule.
#[derive(Clone, Debug)]
pub struct SimAccess {
    /// SHA-256 of each accepted token; empty: loopback clients only, no token.
    tokens: Vec<[u8; 32]>,
    /// An episode untouched for this long is closed.
    pub idle: Duration,
}

/// The client a call comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Client {
    token: Option<[u8; 32]>,
    peer: Option<IpAddr>,
}

fn digest(token: &str) -> [u8; 32] {
    Sha256::digest(token.trim().as_bytes()).into()
}

impl SimAccess {
    /// No token: clients on this machine only.
    pub fn loopback_only() -> SimAccess {
        SimAccess {
            tokens: Vec::new(),
            idle: DEFAULT_IDLE,
        }
    }

    /// Any of `tokens` (blank ones are skipped; none left means [`SimAccess::loopback_only`]).
    pub fn with_tokens(tokens: impl IntoIterator<Item = String>) -> SimAccess {
        SimAccess {
            tokens: tokens
                .into_iter()
                .filter(|t| !t.trim().is_empty())
                .map(|t| digest(&t))
                .collect(),
            idle: DEFAULT_IDLE,
        }
    }

    pub fn with_idle(mut self, idle: Duration) -> SimAccess {
        self.idle = idle;
        self
    }

    /// Whether a token is needed.
    pub fn needs_token(&self) -> bool {
        !self.tokens.is_empty()
    }

    /// The client of `req`, or why it may not call.
    pub(crate) fn client<T>(&self, req: &Request<T>) -> Result<Client, Status> {
        let peer = peer_of(req);
        if self.tokens.is_empty() {
            return match peer {
                Some(ip) if ip.is_loopback() => Ok(Client {
                    token: None,
                    peer,
                }),
                _ => Err(Status::permission_denied(
                    "this Sim API serves only clients on its own machine: its operator gives it tokens \
                     (vb worker --sim-token-file FILE or VB_SIM_TOKEN) to serve others",
                )),
            };
        }
        let header = req
            .metadata()
            .get("authorization")
            .and_then(|v| v.to_str().ok())
            .ok_or_else(|| {
                Status::unauthenticated("missing token: send `authorization: Bearer <token>`")
            })?;
        let token = header.strip_prefix("Bearer ").ok_or_else(|| {
            Status::unauthenticated("authorization header must be `Bearer <token>`")
        })?;
        let d = digest(token);
        if !self.tokens.contains(&d) {
            return Err(Status::unauthenticated("unknown Sim API token"));
        }
        Ok(Client {
            token: Some(d),
            peer,
        })
    }
}

/// The peer address of a request served through [`vb_net`] (plain or TLS).
fn peer_of<T>(req: &Request<T>) -> Option<IpAddr> {
    use tonic::transport::server::TlsConnectInfo;
    let ext = req.extensions();
    ext.get::<vb_net::grpc::ConnInfo>()
        .and_then(|c| c.remote)
        .or_else(|| {
            ext.get::<TlsConnectInfo<vb_net::grpc::ConnInfo>>()
                .and_then(|c| c.get_ref().remote)
        })
        .or_else(|| req.remote_addr())
        .map(|a| a.ip())
}
