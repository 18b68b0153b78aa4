#!/bin/sh
# Sets up the journal's tables in QuestDB before the journal writes: each with
# deduplication on (timestamp, writer, seq), so a chunk the journal sends again
# (its first answer lost) lands once. Runs every statement of schema.sql (one
# per line, written by scripts/deploy-flows.js from the journal's schema) over
# QuestDB's HTTP /exec, once QuestDB answers. Every statement may run again.
#   QUESTDB_HOST, QUESTDB_PORT (9000), QDB_HTTP_USER, QDB_HTTP_PASSWORD
set -eu
url="http://${QUESTDB_HOST}:${QUESTDB_PORT:-9000}/exec"
auth="${QDB_HTTP_USER:-}:${QDB_HTTP_PASSWORD:-}"
sql="$(dirname "$0")/schema.sql"

query() {
  curl --silent --show-error --fail --user "$auth" --get "$url" --data-urlencode "query=$1" >/dev/null
}

tries=0
until query "SELECT 1" 2>/dev/null; do
  tries=$((tries + 1))
  if [ "$tries" -ge "${QUESTDB_WAIT_TRIES:-60}" ]; then
    echo "questdb-schema: QuestDB at $url did not answer" >&2
    exit 1
  fi
  sleep "${QUESTDB_WAIT_S:-2}"
done

while IFS= read -r statement || [ -n "$statement" ]; do
  case "$statement" in '' | --*) continue ;; esac
  query "$statement" || { echo "questdb-schema: refused: $statement" >&2; exit 1; }
done < "$sql"
echo "questdb-schema: the journal's tables deduplicate on (timestamp, writer, seq)"
