-- Roles and owners (issue 15): a token is a user's (submits, and sees only its own submissions), an admin's (sees
-- all) or a worker's (the worker API only); a submission remembers the token that made it; a worker the token it
-- registered with, and only that token may lease, renew or report for it.
ALTER TABLE tokens ADD COLUMN role TEXT NOT NULL DEFAULT 'user';
ALTER TABLE submissions ADD COLUMN owner_token TEXT NOT NULL DEFAULT '';
ALTER TABLE workers ADD COLUMN token_id TEXT NOT NULL DEFAULT '';
