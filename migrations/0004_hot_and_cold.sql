-- The leaderboard at scale. Pages and the API read O(submissions) or O(one submission) rows:
-- 1. trajectories and planner logs leave the hot episodes table for their own, gzip-compressed (the store moves
--    existing ones when it opens, and empties the old columns);
-- 2. each submission's aggregates (overall and per factor, with intervals and matched contrasts: eval's Summary as
--    JSON) are stored, written by the coordinator while results arrive and when the submission ends;
-- 3. a submission knows its number of tasks, and its episodes are indexed in their order (pages of its table).
CREATE TABLE episode_blobs (
    submission_id   TEXT NOT NULL,
    task_id         TEXT NOT NULL,
    trajectory_gz   BYTEA,                 -- gzip of the trajectory CSV
    planner_log_gz  BYTEA,                 -- gzip of the planner's log
    PRIMARY KEY (submission_id, task_id)
);

CREATE TABLE submission_summaries (
    submission_id  TEXT PRIMARY KEY REFERENCES submissions (id),
    finished       BIGINT NOT NULL,        -- finished episodes the summary covers
    successes      BIGINT NOT NULL,
    summary_json   TEXT NOT NULL,
    updated_at     DOUBLE PRECISION NOT NULL
);

ALTER TABLE submissions ADD COLUMN tasks BIGINT NOT NULL DEFAULT 0;
UPDATE submissions SET tasks = (SELECT COUNT(*) FROM episodes e WHERE e.submission_id = submissions.id);
CREATE INDEX episodes_by_order ON episodes (submission_id, ord);
