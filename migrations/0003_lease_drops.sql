-- Leases that ended without a result (expired in a worker's hands, or released by it), per worker token. The
-- coordinator stops leasing to a token that drops many, and an episode's retries count each token once, so
-- one token leasing and dropping cannot use up a submission's episodes.
CREATE TABLE lease_drops (
    token_id       TEXT NOT NULL,
    worker_id      TEXT NOT NULL,
    submission_id  TEXT NOT NULL,
    task_id        TEXT NOT NULL,
    at             DOUBLE PRECISION NOT NULL
);
CREATE INDEX lease_drops_by_token ON lease_drops (token_id, at);
CREATE INDEX lease_drops_by_episode ON lease_drops (submission_id, task_id);
