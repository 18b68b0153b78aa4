-- Written by scripts/deploy-flows.js from lib/journal/schema.js; run by schema.sh, one statement per line.
CREATE TABLE IF NOT EXISTS sugarshack_datapoint (plant SYMBOL, writer SYMBOL, device SYMBOL, entity SYMBOL, value DOUBLE, device_ts DOUBLE, seq LONG, timestamp TIMESTAMP) TIMESTAMP(timestamp) PARTITION BY DAY WAL DEDUP UPSERT KEYS(timestamp, writer, seq);
ALTER TABLE sugarshack_datapoint ADD COLUMN IF NOT EXISTS writer SYMBOL;
ALTER TABLE sugarshack_datapoint DEDUP ENABLE UPSERT KEYS(timestamp, writer, seq);
CREATE TABLE IF NOT EXISTS sugarshack_event (plant SYMBOL, writer SYMBOL, layer SYMBOL, kind SYMBOL, subject SYMBOL, resources SYMBOL, note SYMBOL, waited_ms DOUBLE, held_ms DOUBLE, priority DOUBLE, issue_to_motion_ms DOUBLE, completion_ms DOUBLE, run_ms DOUBLE, queued_ms DOUBLE, retries DOUBLE, seq LONG, timestamp TIMESTAMP) TIMESTAMP(timestamp) PARTITION BY DAY WAL DEDUP UPSERT KEYS(timestamp, writer, seq);
ALTER TABLE sugarshack_event ADD COLUMN IF NOT EXISTS writer SYMBOL;
ALTER TABLE sugarshack_event DEDUP ENABLE UPSERT KEYS(timestamp, writer, seq);
CREATE TABLE IF NOT EXISTS sugarshack_action (plant SYMBOL, writer SYMBOL, action SYMBOL, who SYMBOL, why SYMBOL, target SYMBOL, seq LONG, timestamp TIMESTAMP) TIMESTAMP(timestamp) PARTITION BY DAY WAL DEDUP UPSERT KEYS(timestamp, writer, seq);
ALTER TABLE sugarshack_action ADD COLUMN IF NOT EXISTS writer SYMBOL;
ALTER TABLE sugarshack_action DEDUP ENABLE UPSERT KEYS(timestamp, writer, seq);
CREATE TABLE IF NOT EXISTS sugarshack_timing (plant SYMBOL, writer SYMBOL, series SYMBOL, subject SYMBOL, value_ms DOUBLE, seq LONG, timestamp TIMESTAMP) TIMESTAMP(timestamp) PARTITION BY DAY WAL DEDUP UPSERT KEYS(timestamp, writer, seq);
ALTER TABLE sugarshack_timing ADD COLUMN IF NOT EXISTS writer SYMBOL;
ALTER TABLE sugarshack_timing DEDUP ENABLE UPSERT KEYS(timestamp, writer, seq);
