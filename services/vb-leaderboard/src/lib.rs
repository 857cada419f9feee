//! The HTTP leaderboard: ranking of submissions, breakdowns by elevation level, terrain semantics and obstacle
//! density (tables and SVG charts), reproducibility facts, a live progress page, a page per episode (path over the
//! map; roll, pitch and speed over time) and a JSON API described by an OpenAPI document. It only reads the store.
//!
//! Pages are rendered on the server by askama templates in `web/templates/` ([`pages`], compiled in and escaping
//! every value); no JavaScript.

pub mod cache;
pub mod compare;
pub mod metrics;
pub mod pages;
pub mod public;
pub mod ranking;
pub mod robustness;

use axum::extract::{Path, Query, State};
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::{Json, Router};
use contracts::{Catalog, ServiceError, ServiceErrorCode, WorldPicture};
use public::PublicSubmission;
use serde::Serialize;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use vb_store::{EpisodeRecord, Progress, Reader, StoreError, StoredSummary};

pub const OPENAPI: &str = include_str!("../../../web/openapi.json");

/// Shared state of the leaderboard.
pub struct Leaderboard {
    reader: Reader,
    /// The simulator ranked runs must have run on.
    sim_version: String,
    tasks: Option<ServedTasks>,
    pictures: Mutex<HashMap<u32, Arc<WorldPicture>>>,
    /// The ranking, at most [`cache::TTL`] old, with its page and JSON.
    snapshot: cache::SnapshotCell,
    /// Rendered submission pages.
    pages: cache::PageCache,
    /// Each perception family's robustness table, with what it was computed from.
    families: Mutex<HashMap<String, (robustness::FamilyKey, robustness::Robustness)>>,
    /// Durations of the requests answered (for `/metrics`).
    latency: metrics::Latency,
}

/// Draws world `id` of the served task set at [`pages::MAP_PPM`] pixels per sample (the binary wires
/// `tasks::TaskSet::world_picture`: the leaderboard itself never links the task set or the simulator).
pub type DrawWorld = Arc<dyn Fn(u32) -> Result<WorldPicture, String> + Send + Sync>;

/// The task set a leaderboard serves: its catalog (the reference runs are ranked against, the terrain groups of
/// the density contrasts) and how to draw its worlds.
#[derive(Clone)]
pub struct ServedTasks {
    pub catalog: Arc<Catalog>,
    pub draw: DrawWorld,
}

/// One submission with its progress and summary, as the API returns it.
#[derive(Clone, Debug, Serialize)]
pub struct SubmissionEntry {
    /// Its place among the ranked runs; `None` for a run listed apart ([`SubmissionEntry::unranked`] says why).
    pub rank: Option<usize>,
    pub unranked: Option<ranking::Unranked>,
    /// Finished tasks over the full task set the board ranks on (0 to 1).
    pub coverage: f64,
    pub submission: PublicSubmission,
    pub progress: Progress,
    pub summary: results::summary::Summary,
}

/// The board: every submission, ranked ones first, and what ranked runs ran.
#[derive(Clone, Debug, Serialize)]
pub struct Ranking {
    pub reference: ranking::Reference,
    pub entries: Vec<SubmissionEntry>,
}

/// The Content-Security-Policy of every response: nothing runs (no script source at all), styles and pictures come
/// only from this server, no framing, no forms, no `<base>`.
pub const CSP: &str =
    "default-src 'none'; style-src 'self'; img-src 'self'; base-uri 'none'; form-action 'none'; \
                       frame-ancestors 'none'";

/// Records each request's duration in the latency histogram.
async fn timed(
    State(lb): State<Arc<Leaderboard>>,
    req: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    let t0 = std::time::Instant::now();
    let res = next.run(req).await;
    lb.latency.record(t0.elapsed());
    res
}

async fn security_headers(mut res: Response) -> Response {
    let h = res.headers_mut();
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        header::HeaderValue::from_static(CSP),
    );
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        header::HeaderValue::from_static("nosniff"),
    );
    res
}

/// A request's failure; its HTTP status comes from its [`ServiceErrorCode`] by the one map.
#[derive(Debug, thiserror::Error)]
pub enum WebError {
    #[error("{0}")]
    NotFound(String),
    #[error("{0}")]
    Internal(String),
    #[error(transparent)]
    Store(#[from] StoreError),
}

impl ServiceError for WebError {
    fn error_code(&self) -> ServiceErrorCode {
        match self {
            Self::NotFound(_) => ServiceErrorCode::NotFound,
            Self::Internal(_) => ServiceErrorCode::Internal,
            Self::Store(e) => e.error_code(),
        }
    }
}

impl IntoResponse for WebError {
    fn into_response(self) -> Response {
        let code = StatusCode::from_u16(self.error_code().http_status())
            .unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
        (code, Json(serde_json::json!({ "error": self.to_string() }))).into_response()
    }
}

/// A task id from a URL; text that is not one names no episode.
fn task_id(submission: &str, task: &str) -> Result<contracts::TaskId, WebError> {
    task.parse().map_err(|_| {
        WebError::NotFound(format!(
            "no episode `{task}` in submission `{submission}` (task ids look like w001-t0)"
        ))
    })
}

impl Leaderboard {
    fn catalog(&self) -> Option<&Catalog> {
        self.tasks.as_ref().map(|t| t.catalog.as_ref())
    }

    /// `sim_version`: the simulator ranked runs must have run on; `tasks` gives the reference task set and the
    /// maps drawn under episode paths (pages work without it, minus the map).
    pub fn new(reader: Reader, sim_version: &str, tasks: Option<ServedTasks>) -> Arc<Leaderboard> {
        Arc::new(Leaderboard {
            reader,
            sim_version: sim_version.to_string(),
            tasks,
            pictures: Mutex::new(HashMap::new()),
            snapshot: Default::default(),
            pages: Default::default(),
            families: Default::default(),
            latency: Default::default(),
        })
    }

    pub fn router(self: &Arc<Self>) -> Router {
        Router::new()
            .route("/", get(index))
            .route("/submissions/:id", get(submission_page))
            .route("/submissions/:id/episodes/:task", get(episode_page))
            .route("/worlds/:file", get(world_png))
            .route("/static/style.css", get(style))
            .route("/api/openapi.json", get(openapi))
            .route("/compare/:a/:b", get(compare_page))
            .route("/metrics", get(metrics_text))
            .route("/api/submissions", get(api_submissions))
            .route("/api/submissions/:id", get(api_submission))
            .route("/api/submissions/:id/episodes", get(api_episodes))
            .route("/api/submissions/:id/robustness", get(api_robustness))
            .route("/api/submissions/:id/episodes/:task", get(api_episode))
            .route("/api/compare/:a/:b", get(api_compare))
            .fallback(not_found)
            .with_state(self.clone())
            .layer(axum::middleware::map_response(security_headers))
            .layer(axum::middleware::from_fn_with_state(self.clone(), timed))
    }

    /// A submission's entry from its stored aggregates (computed from its episodes only when the coordinator has
    /// not stored them yet). Progress is counted for a submission still running; an ended one's is final and comes
    /// from the stored counts.
    async fn entry(
        &self,
        sub: PublicSubmission,
        stored: Option<StoredSummary>,
    ) -> Result<SubmissionEntry, WebError> {
        let ended = !sub.state.is_active();
        // An ended submission's aggregates count only when written after it ended (the coordinator writes them then).
        let stored = stored.filter(|m| !ended || sub.finished_at.is_none_or(|f| m.updated_at >= f));
        let summary = match &stored {
            Some(m) => m.summary.clone(),
            None => {
                let eps = public::episodes(&self.reader, &sub).await?;
                vb_store::aggregate::summary_with(&sub.facts, &eps, self.catalog())?
            }
        };
        let progress = match &stored {
            Some(m) if ended => Progress {
                total: sub.tasks,
                finished: m.finished,
                not_run: sub.tasks.saturating_sub(m.finished),
                successes: m.successes,
                ..Progress::default()
            },
            _ => self.reader.progress(&sub.id).await?,
        };
        Ok(SubmissionEntry {
            rank: None,
            unranked: None,
            coverage: 0.0,
            submission: sub,
            progress,
            summary,
        })
    }

    /// What ranked runs must have run: the full loaded task set (or, without one, the newest submission's set and
    /// the most tasks a submission on it has), on this build's simulator, under the paper's rules.
    fn reference(&self, entries: &[SubmissionEntry]) -> ranking::Reference {
        match self.catalog() {
            Some(c) => ranking::Reference::current(
                &c.task_set_version,
                c.all_tasks().len() as u32,
                &self.sim_version,
            ),
            None => {
                // Entries come newest first.
                let version = entries
                    .first()
                    .map_or("", |e| e.submission.task_set_version.as_str());
                let tasks = entries
                    .iter()
                    .filter(|e| e.submission.task_set_version == version)
                    .map(|e| e.progress.total)
                    .max()
                    .unwrap_or(0);
                ranking::Reference::current(version, tasks, &self.sim_version)
            }
        }
    }

    /// Every submission with what they are ranked against. Only comparable runs are ranked (by success rate): see
    /// [`ranking`]. The others follow, unranked, each with why and its coverage. Reads one row per submission
    /// (plus the progress of running ones).
    pub async fn ranked(&self) -> Result<Ranking, WebError> {
        let mut out = Vec::new();
        for (s, m) in public::board(&self.reader).await? {
            out.push(self.entry(s, m).await?);
        }
        let reference = self.reference(&out);
        for e in &mut out {
            let run = ranking::Run {
                state: e.submission.state,
                tasks: e.progress.total,
                finished: e.progress.finished,
                task_set_version: &e.submission.task_set_version,
                sim_version: &e.submission.sim_version,
                rules: e.summary.rules,
                perception: &e.summary.perception,
            };
            e.unranked = run.unranked(&reference);
            e.coverage = run.coverage(&reference);
        }
        out.sort_by(|a, b| {
            let key = |e: &SubmissionEntry| {
                if e.summary.overall.episodes == 0 {
                    -1.0
                } else {
                    e.summary.overall.success_rate
                }
            };
            a.unranked
                .is_some()
                .cmp(&b.unranked.is_some())
                .then(key(b).total_cmp(&key(a)))
                .then(a.submission.seq.cmp(&b.submission.seq))
        });
        let mut rank = 0;
        for e in out.iter_mut().filter(|e| e.unranked.is_none()) {
            rank += 1;
            e.rank = Some(rank);
        }
        Ok(Ranking {
            reference,
            entries: out,
        })
    }

    /// The ranking, read again only when the last reading is older than [`cache::TTL`] (or `fresh` asks for it).
    async fn snapshot(&self, fresh: bool) -> Result<Arc<cache::Snapshot>, WebError> {
        self.snapshot
            .get(fresh, || async {
                let ranking = self.ranked().await?;
                let families = self.all_robustness(&ranking.entries).await?;
                Ok(cache::Snapshot::new(ranking, families))
            })
            .await
    }

    /// One submission's entry with its rank (from the ranking snapshot, read again once if the submission is newer).
    async fn ranked_entry(&self, id: &str) -> Result<SubmissionEntry, WebError> {
        for fresh in [false, true] {
            let snap = self.snapshot(fresh).await?;
            if let Some(e) = snap.entries.iter().find(|e| e.submission.id == id) {
                return Ok(e.clone());
            }
        }
        Err(WebError::NotFound(format!("no submission `{id}`")))
    }

    /// World `id`'s picture and task geometry, drawn once (blocking: call from `spawn_blocking`).
    fn world_picture(&self, id: u32) -> Result<Arc<WorldPicture>, WebError> {
        if let Some(p) = self.pictures.lock().ok().and_then(|m| m.get(&id).cloned()) {
            return Ok(p);
        }
        let served = self.tasks.as_ref().ok_or_else(|| {
            WebError::NotFound("this leaderboard has no task set to draw maps from".into())
        })?;
        if !served.catalog.worlds.contains_key(&id) {
            return Err(WebError::NotFound(format!("no world {id} in the task set")));
        }
        let picture = Arc::new((served.draw)(id).map_err(WebError::Internal)?);
        if let Ok(mut m) = self.pictures.lock() {
            m.insert(id, picture.clone());
        }
        Ok(picture)
    }
}

type St = State<Arc<Leaderboard>>;

/// World `id`'s picture, drawn off the async workers the first time.
async fn picture(lb: &Arc<Leaderboard>, id: u32) -> Result<Arc<WorldPicture>, WebError> {
    let lb = lb.clone();
    tokio::task::spawn_blocking(move || lb.world_picture(id))
        .await
        .map_err(|e| WebError::Internal(e.to_string()))?
}

async fn index(State(lb): St) -> Result<Html<axum::body::Bytes>, WebError> {
    Ok(Html(lb.snapshot(false).await?.html.clone()))
}

/// `?page=N` (from 1) of a submission's episode table.
#[derive(serde::Deserialize)]
struct PageQuery {
    page: Option<usize>,
}

async fn submission_page(
    State(lb): St,
    Path(id): Path<String>,
    Query(q): Query<PageQuery>,
) -> Result<Html<axum::body::Bytes>, WebError> {
    let page = lb
        .pages
        .get((id.clone(), q.page.unwrap_or(1)), || async {
            let sub = public::submission(&lb.reader, &id).await?;
            let stored = lb.reader.stored_summary(&id).await?;
            let (page, offset) =
                pages::submission::page_offset(q.page.unwrap_or(1), sub.tasks as usize);
            let eps =
                public::episodes_range(&lb.reader, &sub, offset, pages::submission::PAGE_SIZE)
                    .await?;
            let entry = lb.entry(sub, stored).await?;
            let snap = lb.snapshot(false).await?;
            let others = pages::submission::compare_links(&id, &snap.entries);
            let family = snap
                .robustness
                .iter()
                .find(|r| r.family == entry.submission.family);
            Ok(pages::submission::page(
                &entry, &eps, page, offset, &others, family,
            ))
        })
        .await?;
    Ok(Html(page))
}

async fn episode_page(
    State(lb): St,
    Path((id, task)): Path<(String, String)>,
) -> Result<Html<String>, WebError> {
    let sub = public::submission(&lb.reader, &id).await?;
    let detail = public::episode_detail(&lb.reader, &id, task_id(&id, &task)?).await?;
    // The page works without its map (no task set served, or a world it does not have).
    let map = if lb.tasks.is_some() {
        picture(&lb, detail.record.world_id).await.ok()
    } else {
        None
    };
    Ok(Html(pages::episode::page(&sub, &detail, map.as_deref())))
}

async fn world_png(State(lb): St, Path(file): Path<String>) -> Result<Response, WebError> {
    let id: u32 = file
        .strip_suffix(".png")
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| WebError::NotFound(format!("no world picture `{file}`")))?;
    let bytes = picture(&lb, id).await?.png.clone();
    Ok((
        [
            (header::CONTENT_TYPE, "image/png"),
            (header::CACHE_CONTROL, "max-age=3600"),
        ],
        bytes,
    )
        .into_response())
}

async fn style() -> Response {
    ([(header::CONTENT_TYPE, "text/css")], pages::style_css()).into_response()
}

async fn metrics_text(State(lb): St) -> Result<Response, WebError> {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64());
    let counts = lb.reader.counts(now).await?;
    Ok((
        [(header::CONTENT_TYPE, "text/plain; version=0.0.4")],
        metrics::exposition(&counts, &lb.latency),
    )
        .into_response())
}

async fn openapi() -> Response {
    ([(header::CONTENT_TYPE, "application/json")], OPENAPI).into_response()
}

async fn api_submissions(State(lb): St) -> Result<Response, WebError> {
    let snap = lb.snapshot(false).await?;
    Ok((
        [(header::CONTENT_TYPE, "application/json")],
        snap.json.clone(),
    )
        .into_response())
}

async fn api_submission(
    State(lb): St,
    Path(id): Path<String>,
) -> Result<Json<SubmissionEntry>, WebError> {
    // An unknown id is answered here, so it cannot make the ranking be re-read.
    public::submission(&lb.reader, &id).await?;
    Ok(Json(lb.ranked_entry(&id).await?))
}

async fn api_episodes(
    State(lb): St,
    Path(id): Path<String>,
) -> Result<Json<Vec<EpisodeRecord>>, WebError> {
    let sub = public::submission(&lb.reader, &id).await?;
    Ok(Json(public::episodes(&lb.reader, &sub).await?))
}

async fn api_episode(
    State(lb): St,
    Path((id, task)): Path<(String, String)>,
) -> Result<Json<public::PublicEpisode>, WebError> {
    Ok(Json(
        public::episode_detail(&lb.reader, &id, task_id(&id, &task)?).await?,
    ))
}

/// The robustness table of the submission's family (one profile when it was submitted alone).
async fn api_robustness(
    State(lb): St,
    Path(id): Path<String>,
) -> Result<Json<robustness::Robustness>, WebError> {
    let entry = lb.ranked_entry(&id).await?;
    let snap = lb.snapshot(false).await?;
    let family = &entry.submission.family;
    // A family of several is in the snapshot already (computed when a member last changed).
    if let Some(r) = snap.robustness.iter().find(|r| &r.family == family) {
        return Ok(Json(r.clone()));
    }
    lb.robustness(family, &snap.entries)
        .await?
        .ok_or_else(|| WebError::NotFound(format!("no submission `{id}`")))
        .map(Json)
}

async fn compare_page(
    State(lb): St,
    Path((a, b)): Path<(String, String)>,
) -> Result<Html<String>, WebError> {
    Ok(Html(pages::compare::page(&lb.compare(&a, &b).await?)))
}

async fn api_compare(
    State(lb): St,
    Path((a, b)): Path<(String, String)>,
) -> Result<Json<compare::Pairwise>, WebError> {
    Ok(Json(lb.compare(&a, &b).await?))
}

async fn not_found() -> WebError {
    WebError::NotFound("no such page".into())
}

/// Serves the leaderboard on `listener` with the default [`vb_net::Limits`] until the future is dropped.
pub async fn serve(lb: Arc<Leaderboard>, listener: tokio::net::TcpListener) -> std::io::Result<()> {
    serve_with(lb, listener, &vb_net::Limits::default()).await
}

/// Serves the leaderboard on `listener` within `limits` (header-read and idle timeouts, a connection limit) until
/// the future is dropped.
pub async fn serve_with(
    lb: Arc<Leaderboard>,
    listener: tokio::net::TcpListener,
    limits: &vb_net::Limits,
) -> std::io::Result<()> {
    vb_net::http::serve(listener, lb.router(), limits, "leaderboard").await
}
