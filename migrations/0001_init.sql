-- Results store of the evaluation service. One schema for SQLite and PostgreSQL: only portable types (TEXT, BIGINT,
-- DOUBLE PRECISION), ids are generated text, times are seconds since the Unix epoch (coordinator clock).

CREATE TABLE tokens (
    id          TEXT PRIMARY KEY,
    name        TEXT NOT NULL,
    hash        TEXT NOT NULL UNIQUE,      -- hex SHA-256 of the token; the token itself is never stored
    created_at  DOUBLE PRECISION NOT NULL,
    revoked     BIGINT NOT NULL DEFAULT 0
);

CREATE TABLE submissions (
    id                TEXT PRIMARY KEY,
    seq               BIGINT NOT NULL UNIQUE, -- submission order (queue order)
    name              TEXT NOT NULL,
    owner             TEXT NOT NULL,          -- name of the token that submitted it
    planner_kind      TEXT NOT NULL,          -- builtin | endpoint | exec | image
    planner_spec      TEXT NOT NULL,          -- builtin name, URL, JSON argv or image reference
    planner_identity  TEXT NOT NULL,          -- what identifies the planner's code (updated from worker reports)
    vehicle           TEXT NOT NULL,
    scale             DOUBLE PRECISION NOT NULL,
    seed              BIGINT NOT NULL,
    step_deadline_s   DOUBLE PRECISION NOT NULL,
    task_set_version  TEXT NOT NULL,
    sim_version       TEXT NOT NULL,
    state             TEXT NOT NULL,          -- queued | running | done | cancelled
    created_at        DOUBLE PRECISION NOT NULL,
    finished_at       DOUBLE PRECISION
);

-- One row per (submission, task): the unit of scheduling and of results. A late duplicate report cannot add a row.
CREATE TABLE episodes (
    submission_id     TEXT NOT NULL REFERENCES submissions (id),
    task_id           TEXT NOT NULL,
    ord               BIGINT NOT NULL,        -- order within the submission
    world_id          BIGINT NOT NULL,
    task_index        BIGINT NOT NULL,
    level             TEXT NOT NULL,
    semantics         TEXT NOT NULL,
    density           TEXT NOT NULL,
    state             TEXT NOT NULL,          -- queued | leased | done | not_run
    attempts          BIGINT NOT NULL DEFAULT 0,
    lease_id          TEXT,
    worker_id         TEXT,
    lease_expires     DOUBLE PRECISION,
    outcome           TEXT,
    reason            TEXT,
    detail            TEXT,
    metrics_json      TEXT,
    trajectory_csv    TEXT,
    planner_log       TEXT,
    sim_version       TEXT,
    planner_identity  TEXT,
    wall_time_s       DOUBLE PRECISION,
    finished_at       DOUBLE PRECISION,
    PRIMARY KEY (submission_id, task_id)
);
CREATE INDEX episodes_by_state ON episodes (state, submission_id, ord);
CREATE INDEX episodes_by_lease ON episodes (lease_id);

CREATE TABLE workers (
    id             TEXT PRIMARY KEY,
    name           TEXT NOT NULL,
    slots          BIGINT NOT NULL,
    sim_version    TEXT NOT NULL,
    registered_at  DOUBLE PRECISION NOT NULL,
    last_seen      DOUBLE PRECISION NOT NULL
);
