-- Submissions a worker cannot run (an image planner whose image it does not have): their episodes go back to the
-- queue without using an attempt and are never leased to that worker again, so they wait for one that can.
CREATE TABLE worker_refusals (
    worker_id      TEXT NOT NULL,
    submission_id  TEXT NOT NULL,
    reason         TEXT NOT NULL,
    at             DOUBLE PRECISION NOT NULL,
    PRIMARY KEY (worker_id, submission_id)
);
