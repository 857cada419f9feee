//! The connection limits of every network server (`vb serve`, `vb coordinator`, `vb leaderboard`, `vb worker
//! --sim`), as flags.

use clap::Args;

#[derive(Args, Clone, Debug)]
#[command(next_help_heading = "Connection limits of each server (vb worker: of its --sim server)")]
pub struct NetArgs {
    /// A client must send a request's headers within this, s: HTTP/1 from connecting or from the previous response
    /// (so also the longest wait of a kept-alive connection), gRPC a new connection's first request (TLS
    /// handshake and HTTP/2 preface included).
    #[arg(long, default_value_t = 10.0)]
    pub header_timeout_s: f64,
    /// A connection that moves no bytes either way for this long is closed, s.
    #[arg(long, default_value_t = 120.0)]
    pub idle_timeout_s: f64,
    /// Connections open at once; past it a new one replaces the oldest that has sent no request yet, or is closed
    /// at once when every one has.
    #[arg(long, default_value_t = 1024)]
    pub max_connections: usize,
    /// Connections open at once from one peer address (so one client cannot hold the whole limit); more are
    /// closed as soon as they are accepted. Behind a reverse proxy every client has its address: raise this.
    /// [default: 256, at most --max-connections]
    #[arg(long)]
    pub max_connections_per_peer: Option<usize>,
    /// gRPC: ping a connection this long after last hearing from it, s (below --idle-timeout-s).
    #[arg(long, default_value_t = 30.0)]
    pub keepalive_s: f64,
    /// gRPC: drop a connection whose peer does not answer a ping within this, s.
    #[arg(long, default_value_t = 20.0)]
    pub keepalive_timeout_s: f64,
}

impl NetArgs {
    pub fn limits(&self) -> anyhow::Result<vb_net::Limits> {
        Ok(vb_net::Limits::from_secs(
            self.header_timeout_s,
            self.idle_timeout_s,
            self.max_connections,
            self.max_connections_per_peer
                .unwrap_or(vb_net::DEFAULT_PER_PEER.min(self.max_connections)),
            self.keepalive_s,
            self.keepalive_timeout_s,
        )?)
    }
}
