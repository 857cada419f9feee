//! What every network server of the service does with a connection before its protocol sees it, in one place: the
//! leaderboard's HTTP/1 ([`http`]), the coordinator's and the `Sim` API's gRPC ([`grpc`]).
//!
//! - [`Incoming`]: the accept loop. At most [`Limits::max_connections`] connections are open at once, at most
//!   [`Limits::max_connections_per_peer`] of them from one peer address. A connection beyond its peer's share is
//!   closed at once; one beyond the whole limit takes the place of the oldest connection that has not sent a
//!   request yet, and is closed at once only when every open connection has (so open descriptors and memory stay
//!   bounded under a flood, one client cannot lock out the others, and a refused client learns it at once instead
//!   of waiting in the backlog); accept errors (out of descriptors) back off instead of spinning.
//! - [`Conn`]: the connection, holding its slot until it is dropped, closed (reads and writes fail) when nothing
//!   has been read or written for [`Limits::idle_timeout`], and, for gRPC, when its first request has not arrived
//!   [`Limits::header_timeout`] after it was accepted (TLS handshake, HTTP/2 preface and headers together).
//! - HTTP/1 request heads must arrive within [`Limits::header_timeout`] (hyper's header-read timeout, which also
//!   counts the wait of a kept-alive connection for its next request); HTTP/2 connections are pinged every
//!   [`Limits::keepalive_interval`] and dropped when a ping is not answered within [`Limits::keepalive_timeout`].

mod conn;
#[cfg(feature = "grpc")]
pub mod grpc;
#[cfg(feature = "http")]
pub mod http;
mod incoming;
mod registry;

pub use conn::Conn;
pub use incoming::Incoming;

use std::time::Duration;

/// [`Limits::max_connections_per_peer`]'s default.
pub const DEFAULT_PER_PEER: usize = 256;

/// The limits of one server (each server counts its own connections).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// HTTP/1: how long a request's head may take to arrive, from the connection's start or the previous response.
    /// gRPC: how long a new connection may take to send its first request.
    pub header_timeout: Duration,
    /// A connection on which nothing is read or written for this long is closed.
    pub idle_timeout: Duration,
    /// Connections open at once; past it a new one replaces the oldest that has sent no request, or is closed.
    pub max_connections: usize,
    /// Connections open at once from one peer address; more are closed as soon as they are accepted (behind a
    /// reverse proxy every client has the proxy's address: raise it to `max_connections` there).
    pub max_connections_per_peer: usize,
    /// HTTP/2: the server pings a connection this long after it last heard from it.
    pub keepalive_interval: Duration,
    /// HTTP/2: a connection whose peer does not answer a ping within this is dropped.
    pub keepalive_timeout: Duration,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            header_timeout: Duration::from_secs(10),
            idle_timeout: Duration::from_secs(120),
            max_connections: 1024,
            max_connections_per_peer: DEFAULT_PER_PEER,
            keepalive_interval: Duration::from_secs(30),
            keepalive_timeout: Duration::from_secs(20),
        }
    }
}

/// Limits that cannot work.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LimitsError {
    #[error("{0} must be a positive number of seconds, at most a day")]
    Duration(&'static str),
    #[error("max connections must be between 1 and 1000000 (got {0})")]
    Connections(usize),
    #[error("max connections per peer must be between 1 and max connections ({max}) (got {got})")]
    PerPeer { got: usize, max: usize },
    #[error(
        "the keepalive interval ({keepalive:?}) must be shorter than the idle timeout ({idle:?}): a gRPC peer \
         that answers pings must not be dropped as idle"
    )]
    KeepaliveNotBelowIdle { keepalive: Duration, idle: Duration },
}

impl Limits {
    /// Limits from seconds, as the command line gives them, checked.
    pub fn from_secs(
        header_timeout_s: f64,
        idle_timeout_s: f64,
        max_connections: usize,
        max_connections_per_peer: usize,
        keepalive_s: f64,
        keepalive_timeout_s: f64,
    ) -> Result<Limits, LimitsError> {
        let secs = |s: f64, name: &'static str| {
            if s.is_finite() && s > 0.0 && s <= 86_400.0 {
                Ok(Duration::from_secs_f64(s))
            } else {
                Err(LimitsError::Duration(name))
            }
        };
        let l = Limits {
            header_timeout: secs(header_timeout_s, "the header timeout")?,
            idle_timeout: secs(idle_timeout_s, "the idle timeout")?,
            max_connections,
            max_connections_per_peer,
            keepalive_interval: secs(keepalive_s, "the keepalive interval")?,
            keepalive_timeout: secs(keepalive_timeout_s, "the keepalive timeout")?,
        };
        l.check()?;
        Ok(l)
    }

    /// Checks limits made in code.
    pub fn check(&self) -> Result<(), LimitsError> {
        if !(1..=1_000_000).contains(&self.max_connections) {
            return Err(LimitsError::Connections(self.max_connections));
        }
        if !(1..=self.max_connections).contains(&self.max_connections_per_peer) {
            return Err(LimitsError::PerPeer {
                got: self.max_connections_per_peer,
                max: self.max_connections,
            });
        }
        for (d, name) in [
            (self.header_timeout, "the header timeout"),
            (self.idle_timeout, "the idle timeout"),
            (self.keepalive_interval, "the keepalive interval"),
            (self.keepalive_timeout, "the keepalive timeout"),
        ] {
            if d.is_zero() || d > Duration::from_secs(86_400) {
                return Err(LimitsError::Duration(name));
            }
        }
        if self.keepalive_interval >= self.idle_timeout {
            return Err(LimitsError::KeepaliveNotBelowIdle {
                keepalive: self.keepalive_interval,
                idle: self.idle_timeout,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_pass_and_nonsense_is_refused() {
        assert_eq!(Limits::default().check(), Ok(()));
        assert_eq!(
            Limits::from_secs(10.0, 120.0, 1024, 256, 30.0, 20.0),
            Ok(Limits::default())
        );
        assert!(matches!(
            Limits::from_secs(0.0, 120.0, 1024, 256, 30.0, 20.0),
            Err(LimitsError::Duration("the header timeout"))
        ));
        assert!(matches!(
            Limits::from_secs(10.0, f64::NAN, 1024, 256, 30.0, 20.0),
            Err(LimitsError::Duration("the idle timeout"))
        ));
        assert!(matches!(
            Limits::from_secs(10.0, 120.0, 0, 1, 30.0, 20.0),
            Err(LimitsError::Connections(0))
        ));
        assert!(matches!(
            Limits::from_secs(10.0, 20.0, 1024, 256, 30.0, 20.0),
            Err(LimitsError::KeepaliveNotBelowIdle { .. })
        ));
        assert!(matches!(
            Limits::from_secs(10.0, 120.0, 64, 65, 30.0, 20.0),
            Err(LimitsError::PerPeer { got: 65, max: 64 })
        ));
    }
}
