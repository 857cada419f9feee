//! [`Registry`]: the open connections of one server, counted in all and per peer address, and the ones that have
//! not sent a request yet, oldest first, so that a full server can shed one of those for a new client.
//!
//! The policy is a reverse proxy's: each peer address gets at most [`crate::Limits::max_connections_per_peer`]
//! (one client cannot hold the whole limit), and when the whole limit is reached a new connection takes the place
//! of the oldest one that has not sent a request yet (head-less connections from many addresses cannot lock out a
//! client that means to talk). Only when every open connection has sent a request is a new one refused.

use std::collections::BTreeMap;
use std::net::IpAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::Waker;

/// What a connection, the requests on it and the registry share.
#[derive(Debug, Default)]
pub(crate) struct ConnState {
    requested: AtomicBool,
    shed: AtomicBool,
    /// The task waiting on the connection's socket, woken when the connection is shed.
    waker: Mutex<Option<Waker>>,
}

impl ConnState {
    pub(crate) fn mark_request(&self) {
        self.requested.store(true, Ordering::Relaxed);
    }

    pub(crate) fn requested(&self) -> bool {
        self.requested.load(Ordering::Relaxed)
    }

    /// Whether the server shed this connection for a new one (it is to close at once).
    pub(crate) fn is_shed(&self) -> bool {
        self.shed.load(Ordering::Acquire)
    }

    /// Remembers the task to wake if the connection is shed while it waits.
    pub(crate) fn park(&self, waker: &Waker) {
        if let Ok(mut w) = self.waker.lock() {
            if !w.as_ref().is_some_and(|old| old.will_wake(waker)) {
                *w = Some(waker.clone());
            }
        }
    }

    fn shed_now(&self) {
        self.shed.store(true, Ordering::Release);
        if let Some(w) = self.waker.lock().ok().and_then(|mut w| w.take()) {
            w.wake();
        }
    }
}

/// Why a new connection was not admitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Refusal {
    /// Its peer address holds its whole share.
    PeerShare,
    /// The server is full and every open connection has sent a request.
    Full,
}

#[derive(Debug, Default)]
struct Inner {
    open: usize,
    per_peer: BTreeMap<IpAddr, usize>,
    /// Connections that had sent no request when last looked at, by admission order.
    headless: BTreeMap<u64, (Option<IpAddr>, Arc<ConnState>)>,
    next: u64,
}

impl Inner {
    fn release(&mut self, peer: Option<IpAddr>) {
        self.open = self.open.saturating_sub(1);
        if let Some(ip) = peer {
            if let Some(n) = self.per_peer.get_mut(&ip) {
                *n -= 1;
                if *n == 0 {
                    self.per_peer.remove(&ip);
                }
            }
        }
    }
}

/// The open connections of one server.
#[derive(Debug)]
pub(crate) struct Registry {
    inner: Mutex<Inner>,
    max: usize,
    per_peer: usize,
}

impl Registry {
    pub(crate) fn new(max: usize, per_peer: usize) -> Arc<Registry> {
        Arc::new(Registry {
            inner: Mutex::default(),
            max,
            per_peer,
        })
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        // A panic while holding it leaves only counts behind, which stay consistent.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Connections open now (shed ones no longer count).
    pub(crate) fn open(&self) -> usize {
        self.lock().open
    }

    /// Admits a connection from `peer`, shedding the oldest head-less one when the server is full. The returned
    /// [`Slot`] releases its place when dropped.
    pub(crate) fn admit(self: &Arc<Self>, peer: Option<IpAddr>) -> Result<(Slot, bool), Refusal> {
        let mut g = self.lock();
        if let Some(ip) = peer {
            if g.per_peer.get(&ip).copied().unwrap_or(0) >= self.per_peer {
                return Err(Refusal::PeerShare);
            }
        }
        let mut shed = false;
        if g.open >= self.max {
            // The oldest connection still without a request makes way; ones that sent a request since leave the
            // list as they are met.
            loop {
                let Some((_, (victim_peer, state))) = g.headless.pop_first() else {
                    return Err(Refusal::Full);
                };
                if state.requested() {
                    continue;
                }
                state.shed_now();
                g.release(victim_peer);
                shed = true;
                break;
            }
        }
        g.open += 1;
        if let Some(ip) = peer {
            *g.per_peer.entry(ip).or_insert(0) += 1;
        }
        let seq = g.next;
        g.next += 1;
        let state = Arc::new(ConnState::default());
        g.headless.insert(seq, (peer, state.clone()));
        Ok((
            Slot {
                registry: self.clone(),
                peer,
                seq,
                state,
            },
            shed,
        ))
    }
}

/// A connection's place in its [`Registry`].
#[derive(Debug)]
pub(crate) struct Slot {
    registry: Arc<Registry>,
    peer: Option<IpAddr>,
    seq: u64,
    pub(crate) state: Arc<ConnState>,
}

impl Drop for Slot {
    fn drop(&mut self) {
        let mut g = self.registry.lock();
        g.headless.remove(&self.seq);
        // A shed connection's place was handed to the one that shed it.
        if !self.state.is_shed() {
            g.release(self.peer);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ip(last: u8) -> Option<IpAddr> {
        Some(IpAddr::from([127, 0, 0, last]))
    }

    #[test]
    fn a_peer_gets_its_share_and_a_full_server_sheds_the_oldest_headless_connection() {
        let r = Registry::new(4, 2);
        let a1 = r.admit(ip(1)).unwrap().0;
        let a2 = r.admit(ip(1)).unwrap().0;
        assert_eq!(r.admit(ip(1)).unwrap_err(), Refusal::PeerShare);
        let b1 = r.admit(ip(2)).unwrap().0;
        b1.state.mark_request();
        let c1 = r.admit(ip(3)).unwrap().0;
        assert_eq!(r.open(), 4);
        // Full: the oldest head-less one (a1) makes way; b1 has sent a request and is kept.
        let (d1, shed) = r.admit(ip(4)).unwrap();
        assert!(shed);
        assert!(a1.state.is_shed() && !b1.state.is_shed());
        assert_eq!(r.open(), 4);
        drop(a1);
        assert_eq!(r.open(), 4, "a shed connection's place went to the new one");
        // Peer 1 has one connection left, so it may open another.
        let (a3, shed) = r.admit(ip(1)).unwrap();
        assert!(shed, "a2 was the oldest head-less one");
        assert!(a2.state.is_shed());
        for s in [&c1, &d1, &a3] {
            s.state.mark_request();
        }
        assert_eq!(r.admit(ip(5)).unwrap_err(), Refusal::Full);
        drop((a2, b1, c1, d1, a3));
        assert_eq!(r.open(), 0);
        assert!(r.lock().per_peer.is_empty() && r.lock().headless.is_empty());
    }
}
