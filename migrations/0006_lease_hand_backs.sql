-- Leases given back unrun, per worker token: handed back by a stopping worker, or refused by one that cannot run the
-- submission. Neither uses an attempt of the episode, but a token that gives back many leases in a window (a stolen
-- token leasing and handing back in a loop) gets no new leases for a while, like one that drops them.
CREATE TABLE lease_hand_backs (
    token_id       TEXT NOT NULL,
    worker_id      TEXT NOT NULL,
    submission_id  TEXT NOT NULL,
    task_id        TEXT NOT NULL,
    at             DOUBLE PRECISION NOT NULL
);
CREATE INDEX lease_hand_backs_by_token ON lease_hand_backs (token_id, at);
