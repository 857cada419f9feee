#!/usr/bin/env bash
# Installs PostgreSQL from Debian's packages if needed, starts a throw-away server on a private port and prints the
# admin URL for the store tests (VB_TEST_POSTGRES_URL): `export VB_TEST_POSTGRES_URL=$(.ci/postgres.sh)`;
# `.ci/postgres.sh stop` stops it.
set -euo pipefail
PORT="${VB_PG_PORT:-55432}"
if ! ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1; then
    echo "installing postgresql (apt)" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q postgresql >&2
fi
PGBIN="$(ls -d /usr/lib/postgresql/*/bin | sort -V | tail -1)"
DATA="${VB_PG_DATA:-/tmp/vb-ci-postgres}"
RUNAS=""
if [ "$(id -u)" -eq 0 ]; then RUNAS="runuser -u postgres --"; fi
if [ "${1:-}" = "stop" ]; then
    $RUNAS "$PGBIN/pg_ctl" -D "$DATA" stop -m fast >/dev/null 2>&1 || true
    exit 0
fi
if [ -f "$DATA/postmaster.pid" ]; then
    $RUNAS "$PGBIN/pg_ctl" -D "$DATA" stop -m immediate >&2 || true
fi
rm -rf "$DATA"
mkdir -p "$DATA"
[ "$(id -u)" -eq 0 ] && chown postgres "$DATA"
$RUNAS "$PGBIN/initdb" -D "$DATA" -A trust -U postgres >/dev/null
$RUNAS "$PGBIN/pg_ctl" -D "$DATA" -o "-p $PORT -k /tmp -c listen_addresses=127.0.0.1 -c fsync=off" -l "$DATA/server.log" -w start >&2
echo "postgres://postgres@127.0.0.1:$PORT/postgres"
