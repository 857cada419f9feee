-- Perception profiles (issue 61): the profile a submission runs under, by identity ("ideal", "nominal@1f2e...") and
-- with its parameters as canonical JSON for the workers (empty for ideal); and its family, the first submission of
-- the request that submitted it under several profiles (NULL: its own id). Rows from before are ideal and alone.
ALTER TABLE submissions ADD COLUMN perception TEXT NOT NULL DEFAULT 'ideal';
ALTER TABLE submissions ADD COLUMN perception_params TEXT NOT NULL DEFAULT '';
ALTER TABLE submissions ADD COLUMN family TEXT;
