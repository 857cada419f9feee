//! [`Registry`]: the open connections of one server, counted in all and per peer address, and the ones that have
//! not sent a request yet, per peer and oldest first, so that a full server can shed one of those for a new client.
//!
//! The policy is a reverse proxy's: each peer address gets at most [`crate::Limits::max_connections_per_peer`]
//! (one client cannot hold the whole limit), and when the whole limit is reached a new connection takes the place
//! of a head-less one (head-less connections from many addresses cannot lock out a client that means to talk). The
//! one shed is the oldest head-less connection of the peer that holds the most connections (ties: the peer whose
//! head-less connection is oldest), so a flood makes way from its own heaviest address and not from a client whose
//! only connection has yet to send its request. Only when every open connection has sent a request is a new one
//! refused. Every step is O(log n) in the open connections.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BTreeSet};
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

/// A peer's place in the shedding order: its open connections, then the age of its oldest head-less one.
type LoadKey = (usize, Reverse<u64>, Option<IpAddr>);

#[derive(Debug, Default)]
struct Inner {
    open: usize,
    per_peer: BTreeMap<IpAddr, usize>,
    /// Per peer, its connections that had sent no request when last looked at, by admission order.
    headless: BTreeMap<Option<IpAddr>, BTreeMap<u64, Arc<ConnState>>>,
    /// The peers with an entry in `headless`, in shedding order (the last is shed from first).
    by_load: BTreeSet<LoadKey>,
    next: u64,
}

impl Inner {
    fn key(&self, peer: Option<IpAddr>) -> Option<LoadKey> {
        let oldest = *self.headless.get(&peer)?.keys().next()?;
        let load = peer.map_or(0, |ip| self.per_peer.get(&ip).copied().unwrap_or(0));
        Some((load, Reverse(oldest), peer))
    }

    /// Applies `change`, which may alter `peer`'s load or head-less connections, keeping `by_load` in step.
    fn rekey<T>(&mut self, peer: Option<IpAddr>, change: impl FnOnce(&mut Inner) -> T) -> T {
        if let Some(k) = self.key(peer) {
            self.by_load.remove(&k);
        }
        let out = change(self);
        if self.headless.get(&peer).is_some_and(BTreeMap::is_empty) {
            self.headless.remove(&peer);
        }
        if let Some(k) = self.key(peer) {
            self.by_load.insert(k);
        }
        out
    }

    fn release(&mut self, peer: Option<IpAddr>) {
        self.open = self.open.saturating_sub(1);
        self.rekey(peer, |g| {
            if let Some(ip) = peer {
                if let Some(n) = g.per_peer.get_mut(&ip) {
                    *n -= 1;
                    if *n == 0 {
                        g.per_peer.remove(&ip);
                    }
                }
            }
        });
    }

    /// Sheds the oldest head-less connection of the heaviest peer; false if every open connection has sent a
    /// request. Connections that sent one since they were listed leave the list as they are met.
    fn shed_one(&mut self) -> bool {
        while let Some(&k) = self.by_load.last() {
            self.by_load.remove(&k);
            let peer = k.2;
            let popped = self.rekey(peer, |g| {
                g.headless
                    .get_mut(&peer)
                    .and_then(BTreeMap::pop_first)
                    .map(|(_, s)| s)
            });
            let Some(state) = popped else { continue };
            if state.requested() {
                continue;
            }
            state.shed_now();
            self.release(peer);
            return true;
        }
        false
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

    /// Admits a connection from `peer`, shedding a head-less one (see the module's policy) when the server is full. The returned
    /// [`Slot`] releases its place when dropped.
    pub(crate) fn admit(self: &Arc<Self>, peer: Option<IpAddr>) -> Result<(Slot, bool), Refusal> {
        let mut g = self.lock();
        if let Some(ip) = peer {
            if g.per_peer.get(&ip).copied().unwrap_or(0) >= self.per_peer {
                return Err(Refusal::PeerShare);
            }
        }
        let shed = g.open >= self.max;
        if shed && !g.shed_one() {
            return Err(Refusal::Full);
        }
        g.open += 1;
        let seq = g.next;
        g.next += 1;
        let state = Arc::new(ConnState::default());
        g.rekey(peer, |g| {
            if let Some(ip) = peer {
                *g.per_peer.entry(ip).or_insert(0) += 1;
            }
            g.headless
                .entry(peer)
                .or_default()
                .insert(seq, state.clone());
        });
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
        let (peer, seq) = (self.peer, self.seq);
        g.rekey(peer, |g| {
            if let Some(q) = g.headless.get_mut(&peer) {
                q.remove(&seq);
            }
        });
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
        let g = r.lock();
        assert!(g.per_peer.is_empty() && g.headless.is_empty() && g.by_load.is_empty());
    }

    #[test]
    fn a_full_server_sheds_from_the_peer_holding_the_most_connections_before_an_older_lone_client()
    {
        let r = Registry::new(4, 3);
        // A client's one connection, its request not yet arrived, then a flood from one address fills the server.
        let client = r.admit(ip(2)).unwrap().0;
        let flood: Vec<Slot> = (0..3).map(|_| r.admit(ip(1)).unwrap().0).collect();
        // Two more flooding addresses: each new connection sheds the flood's oldest, not the older lone client.
        let (b, shed) = r.admit(ip(3)).unwrap();
        assert!(shed && flood[0].state.is_shed() && !client.state.is_shed());
        let (c, _) = r.admit(ip(4)).unwrap();
        assert!(flood[1].state.is_shed() && !client.state.is_shed());
        // Now every peer holds one: the oldest head-less connection goes, which is the client's.
        client.state.mark_request();
        let (d, _) = r.admit(ip(5)).unwrap();
        assert!(!client.state.is_shed(), "it has sent its request");
        assert!(flood[2].state.is_shed());
        assert_eq!(r.open(), 4);
        drop((client, flood, b, c, d));
        let g = r.lock();
        assert_eq!(g.open, 0);
        assert!(g.per_peer.is_empty() && g.headless.is_empty() && g.by_load.is_empty());
    }
}
