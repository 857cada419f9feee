-- Leases a stopping worker handed back unrun, per worker token. A hand-back uses no attempt of the episode, but a
-- token that hands back many leases in a window (a stolen token leasing and handing back in a loop) gets no new
-- leases for a while, like one that drops them.
CREATE TABLE lease_hand_backs (
    token_id       TEXT NOT NULL,
    worker_id      TEXT NOT NULL,
    submission_id  TEXT NOT NULL,
    task_id        TEXT NOT NULL,
    at             DOUBLE PRECISION NOT NULL
);
CREATE INDEX lease_hand_backs_by_token ON lease_hand_backs (token_id, at);
