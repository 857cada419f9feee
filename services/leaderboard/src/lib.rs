//! The HTTP leaderboard: ranking of submissions, breakdowns by elevation level, terrain semantics and obstacle
//! density (tables and SVG charts), reproducibility facts, a live progress page, a page per episode (path over the
//! map; roll, pitch and speed over time) and a JSON API described by an OpenAPI document. It only reads the store.
//!
//! Pages are rendered on the server by askama templates in `web/templates/` ([`pages`], compiled in and escaping
//! every value); no JavaScript.

pub mod pages;
pub mod public;

use axum::extract::{Path, Query, State};
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::{Json, Router};
use eval::EpisodeRow;
use serde::Serialize;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use tasks::TaskSet;
use vb_store::{EpisodeRecord, Progress, Reader, StoreError, Submission};

pub const OPENAPI: &str = include_str!("../../../web/openapi.json");

/// Shared state of the leaderboard.
pub struct Leaderboard {
    reader: Reader,
    set: Option<Arc<TaskSet>>,
    world_png: Mutex<HashMap<u32, Arc<Vec<u8>>>>,
}

/// One submission with its progress and summary, as the API returns it.
#[derive(Clone, Debug, Serialize)]
pub struct SubmissionEntry {
    pub rank: Option<usize>,
    pub submission: Submission,
    pub progress: Progress,
    pub summary: eval::summary::Summary,
}

/// The Content-Security-Policy of every response: nothing runs (no script source at all), styles and pictures come
/// only from this server, no framing, no forms, no `<base>`.
pub const CSP: &str =
    "default-src 'none'; style-src 'self'; img-src 'self'; base-uri 'none'; form-action 'none'; \
                       frame-ancestors 'none'";

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

#[derive(Debug)]
pub enum WebError {
    NotFound(String),
    Internal(String),
}

impl From<StoreError> for WebError {
    fn from(e: StoreError) -> Self {
        match e {
            StoreError::UnknownSubmission(_) | StoreError::UnknownEpisode { .. } => {
                WebError::NotFound(e.to_string())
            }
            other => WebError::Internal(other.to_string()),
        }
    }
}

impl IntoResponse for WebError {
    fn into_response(self) -> Response {
        let (code, msg) = match self {
            WebError::NotFound(m) => (StatusCode::NOT_FOUND, m),
            WebError::Internal(m) => (StatusCode::INTERNAL_SERVER_ERROR, m),
        };
        (code, Json(serde_json::json!({ "error": msg }))).into_response()
    }
}

/// Turns stored finished episodes into the evaluation rows the summaries are computed from. `set`, when it is the
/// submission's task set, gives each world's terrain group (for the matched density contrasts).
pub fn rows(sub: &Submission, eps: &[EpisodeRecord], set: Option<&TaskSet>) -> Vec<EpisodeRow> {
    let set = set.filter(|s| s.version() == sub.task_set_version);
    eps.iter()
        .filter(|e| e.state == "done")
        .map(|e| EpisodeRow {
            task_id: e.task_id.clone(),
            world_id: e.world_id,
            task_index: e.task_index,
            level: e.level.clone(),
            semantics: e.semantics.clone(),
            density: e.density.clone(),
            terrain: set
                .and_then(|s| s.world_meta(e.world_id).ok())
                .and_then(|m| m.terrain),
            planner: sub.name.clone(),
            vehicle: sub.vehicle.clone(),
            scale: sub.scale,
            seed: sub.seed,
            task_set_version: sub.task_set_version.clone(),
            sim_version: e
                .sim_version
                .clone()
                .unwrap_or_else(|| sub.sim_version.clone()),
            // The service runs every episode under the paper's rules.
            rules: Default::default(),
            outcome: e.outcome.clone().unwrap_or_default(),
            reason: e.reason.clone().unwrap_or_default(),
            detail: e.detail.clone().unwrap_or_default(),
            metrics: e
                .metrics_json
                .as_deref()
                .and_then(|m| serde_json::from_str(m).ok())
                .unwrap_or_default(),
            wall_time_s: e.wall_time_s.unwrap_or(0.0),
        })
        .collect()
}

impl Leaderboard {
    /// `set` gives the maps drawn under episode paths (pages work without it, minus the map).
    pub fn new(reader: Reader, set: Option<TaskSet>) -> Arc<Leaderboard> {
        Arc::new(Leaderboard {
            reader,
            set: set.map(Arc::new),
            world_png: Mutex::new(HashMap::new()),
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
            .route("/api/submissions", get(api_submissions))
            .route("/api/submissions/:id", get(api_submission))
            .route("/api/submissions/:id/episodes", get(api_episodes))
            .route("/api/submissions/:id/episodes/:task", get(api_episode))
            .fallback(not_found)
            .with_state(self.clone())
            .layer(axum::middleware::map_response(security_headers))
    }

    async fn entry(&self, sub: Submission) -> Result<SubmissionEntry, WebError> {
        let progress = self.reader.progress(&sub.id).await?;
        let eps = public::episodes(&self.reader, &sub.id).await?;
        let mut summary = eval::summary::summarise(&rows(&sub, &eps, self.set.as_deref()));
        summary.planner = sub.name.clone();
        summary.vehicle = sub.vehicle.clone();
        summary.scale = sub.scale;
        summary.task_set_version = sub.task_set_version.clone();
        summary.sim_version = sub.sim_version.clone();
        Ok(SubmissionEntry {
            rank: None,
            submission: sub,
            progress,
            summary,
        })
    }

    /// Every submission. Only complete runs are ranked (by success rate): submissions that finished every task of
    /// the task set. Partial ones (fewer tasks, cancelled, still running) follow, unranked, so three lucky episodes
    /// never top the board.
    pub async fn ranked(&self) -> Result<Vec<SubmissionEntry>, WebError> {
        let mut out = Vec::new();
        for s in public::submissions(&self.reader).await? {
            out.push(self.entry(s).await?);
        }
        let full = match &self.set {
            Some(set) => set.world_ids().len() as u32 * 10,
            None => out.iter().map(|e| e.progress.total).max().unwrap_or(0),
        };
        let complete = |e: &SubmissionEntry| {
            e.submission.state == "done"
                && e.progress.total == full
                && e.progress.finished == e.progress.total
        };
        out.sort_by(|a, b| {
            let key = |e: &SubmissionEntry| {
                if e.summary.overall.episodes == 0 {
                    -1.0
                } else {
                    e.summary.overall.success_rate
                }
            };
            complete(b)
                .cmp(&complete(a))
                .then(key(b).total_cmp(&key(a)))
                .then(a.submission.seq.cmp(&b.submission.seq))
        });
        let mut rank = 0;
        for e in &mut out {
            if complete(e) {
                rank += 1;
                e.rank = Some(rank);
            }
        }
        Ok(out)
    }

    fn world_png_bytes(&self, id: u32) -> Result<Arc<Vec<u8>>, WebError> {
        if let Some(b) = self.world_png.lock().ok().and_then(|m| m.get(&id).cloned()) {
            return Ok(b);
        }
        let set = self.set.as_ref().ok_or_else(|| {
            WebError::NotFound("this leaderboard has no task set to draw maps from".into())
        })?;
        let mut record = set
            .record(id)
            .map_err(|e| WebError::NotFound(e.to_string()))?;
        record.tasks.clear();
        let img = tasks::render::render_world(&record, pages::MAP_PPM);
        let mut bytes = Vec::new();
        img.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| WebError::Internal(format!("encoding the map of world {id}: {e}")))?;
        let bytes = Arc::new(bytes);
        if let Ok(mut m) = self.world_png.lock() {
            m.insert(id, bytes.clone());
        }
        Ok(bytes)
    }
}

type St = State<Arc<Leaderboard>>;

async fn index(State(lb): St) -> Result<Html<String>, WebError> {
    let entries = lb.ranked().await?;
    Ok(Html(pages::board::index(&entries)))
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
) -> Result<Html<String>, WebError> {
    let sub = public::submission(&lb.reader, &id).await?;
    let entry = lb.entry(sub).await?;
    let eps = public::episodes(&lb.reader, &id).await?;
    Ok(Html(pages::submission::page(
        &entry,
        &eps,
        q.page.unwrap_or(1),
    )))
}

async fn episode_page(
    State(lb): St,
    Path((id, task)): Path<(String, String)>,
) -> Result<Html<String>, WebError> {
    let sub = public::submission(&lb.reader, &id).await?;
    let detail = public::episode_detail(&lb.reader, &id, &task).await?;
    let world_task = lb.set.as_ref().and_then(|set| {
        let w = detail.record.world_id;
        let t = detail.record.task_index as usize;
        let tasks = set.tasks(w, 1.0).ok()?;
        let task = tasks.into_iter().nth(t)?;
        let world = set.world(w, 1.0).ok()?;
        Some((world, task))
    });
    Ok(Html(pages::episode::page(
        &sub,
        &detail,
        world_task.as_ref(),
    )))
}

async fn world_png(State(lb): St, Path(file): Path<String>) -> Result<Response, WebError> {
    let id: u32 = file
        .strip_suffix(".png")
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| WebError::NotFound(format!("no world picture `{file}`")))?;
    let lb2 = lb.clone();
    let bytes = tokio::task::spawn_blocking(move || lb2.world_png_bytes(id))
        .await
        .map_err(|e| WebError::Internal(e.to_string()))??;
    Ok((
        [
            (header::CONTENT_TYPE, "image/png"),
            (header::CACHE_CONTROL, "max-age=3600"),
        ],
        bytes.as_ref().clone(),
    )
        .into_response())
}

async fn style() -> Response {
    ([(header::CONTENT_TYPE, "text/css")], pages::style_css()).into_response()
}

async fn openapi() -> Response {
    ([(header::CONTENT_TYPE, "application/json")], OPENAPI).into_response()
}

async fn api_submissions(State(lb): St) -> Result<Json<Vec<SubmissionEntry>>, WebError> {
    Ok(Json(lb.ranked().await?))
}

async fn api_submission(
    State(lb): St,
    Path(id): Path<String>,
) -> Result<Json<SubmissionEntry>, WebError> {
    let ranked = lb.ranked().await?;
    ranked
        .into_iter()
        .find(|e| e.submission.id == id)
        .map(Json)
        .ok_or_else(|| WebError::NotFound(format!("no submission `{id}`")))
}

async fn api_episodes(
    State(lb): St,
    Path(id): Path<String>,
) -> Result<Json<Vec<EpisodeRecord>>, WebError> {
    public::submission(&lb.reader, &id).await?;
    Ok(Json(public::episodes(&lb.reader, &id).await?))
}

async fn api_episode(
    State(lb): St,
    Path((id, task)): Path<(String, String)>,
) -> Result<Json<vb_store::EpisodeDetail>, WebError> {
    Ok(Json(public::episode_detail(&lb.reader, &id, &task).await?))
}

async fn not_found() -> WebError {
    WebError::NotFound("no such page".into())
}

/// Serves the leaderboard on `listener` until the future is dropped.
pub async fn serve(lb: Arc<Leaderboard>, listener: tokio::net::TcpListener) -> std::io::Result<()> {
    axum::serve(listener, lb.router()).await
}
