//! What keeps the leaderboard fast under load: the ranking is read from the store at most once per [`TTL`] and
//! rendered once per reading (requests during a re-reading get the previous one rather than wait), and each
//! submission page is rendered at most once per [`TTL`].

use crate::{Ranking, SubmissionEntry, WebError};
use axum::body::Bytes;
use std::collections::HashMap;
use std::future::Future;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::time::{Duration, Instant};

/// How long a reading of the ranking, or a rendered submission page, is reused: pages may be this much behind the
/// store.
pub const TTL: Duration = Duration::from_secs(1);

/// Rendered submission pages kept at most (expired ones are dropped first when full).
const MAX_PAGES: usize = 512;

/// The ranking as read at `at`, with its page and JSON (shared by every response, not copied).
pub struct Snapshot {
    pub at: Instant,
    pub reference: crate::ranking::Reference,
    pub entries: Vec<SubmissionEntry>,
    /// The families of submissions under several perception profiles.
    pub robustness: Vec<crate::robustness::Robustness>,
    pub html: Bytes,
    pub json: Bytes,
}

impl Snapshot {
    pub fn new(ranking: Ranking, robustness: Vec<crate::robustness::Robustness>) -> Snapshot {
        let Ranking { reference, entries } = ranking;
        let html = crate::pages::board::index(&entries, &reference, &robustness);
        let json =
            serde_json::to_string(&entries).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"));
        Snapshot {
            at: Instant::now(),
            reference,
            entries,
            robustness,
            html: html.into(),
            json: json.into(),
        }
    }
}

/// The current ranking snapshot; one request re-reads it when it is older than [`TTL`] while the others are served
/// the previous one.
#[derive(Default)]
pub struct SnapshotCell {
    current: RwLock<Option<Arc<Snapshot>>>,
    refreshing: AtomicBool,
}

/// Clears the refreshing flag however the re-reading ends (an error or a dropped request included).
struct Refreshing<'a>(&'a AtomicBool);

impl Drop for Refreshing<'_> {
    fn drop(&mut self) {
        self.0.store(false, Ordering::Release);
    }
}

impl SnapshotCell {
    /// The snapshot, read again with `build` when it is stale (or `force`).
    pub async fn get<F, Fut>(&self, force: bool, build: F) -> Result<Arc<Snapshot>, WebError>
    where
        F: FnOnce() -> Fut,
        Fut: Future<Output = Result<Snapshot, WebError>>,
    {
        let current = self.current.read().ok().and_then(|c| c.clone());
        if let Some(s) = &current {
            if !force && s.at.elapsed() < TTL {
                return Ok(s.clone());
            }
            if !force && self.refreshing.swap(true, Ordering::AcqRel) {
                // Another request is reading the store: this one gets the previous snapshot.
                return Ok(s.clone());
            }
        } else {
            self.refreshing.store(true, Ordering::Release);
        }
        let _flag = Refreshing(&self.refreshing);
        let snap = Arc::new(build().await?);
        if let Ok(mut c) = self.current.write() {
            *c = Some(snap.clone());
        }
        Ok(snap)
    }
}

/// A page's key: the submission and the page of its episode table.
type PageKey = (String, usize);

/// Rendered pages by key, each reused for [`TTL`].
#[derive(Default)]
pub struct PageCache {
    pages: Mutex<HashMap<PageKey, (Instant, Bytes)>>,
}

impl PageCache {
    pub async fn get<F, Fut>(&self, key: PageKey, build: F) -> Result<Bytes, WebError>
    where
        F: FnOnce() -> Fut,
        Fut: Future<Output = Result<String, WebError>>,
    {
        if let Some((at, page)) = self.pages.lock().ok().and_then(|m| m.get(&key).cloned()) {
            if at.elapsed() < TTL {
                return Ok(page);
            }
        }
        let page = Bytes::from(build().await?);
        if let Ok(mut m) = self.pages.lock() {
            if m.len() >= MAX_PAGES {
                m.retain(|_, (at, _)| at.elapsed() < TTL);
                if m.len() >= MAX_PAGES {
                    m.clear();
                }
            }
            m.insert(key, (Instant::now(), page.clone()));
        }
        Ok(page)
    }
}
