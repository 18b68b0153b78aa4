//! Saved state keeps its wire format: JSON written before times were
//! [`Millis`] reads back, and the same run writes the same JSON, times as
//! integers. The literals were written by the core when times were `u64`.

use sugarshack_core::alarm::{AlarmKind, Alarms, AlarmsSnapshot, Condition};
use sugarshack_core::clearance::Attribution;
use sugarshack_core::interlock::{Interlock, InterlockConfig, RestoreOptions, Snapshot};
use sugarshack_core::time::{ms, Millis};

const INTERLOCK: &str = r#"{"version":2,"takenAtMs":1700000000400,"configured":["YEL","RED","GRN"],"resources":[{"name":"YEL","state":{"state":"held","operation":"load"}},{"name":"RED","state":{"state":"faulted","cause":"manual","note":"estop","sinceMs":1700000000300}},{"name":"GRN","state":{"state":"free"}}],"queue":[{"operation":"flit","priority":92,"resources":["YEL","RED"],"sinceMs":1700000000250,"waitedMs":0}],"holds":[{"operation":"load","priority":20,"resources":["YEL"],"sinceMs":1700000000100,"waitedMs":0}]}"#;

const ALARMS: &str = r#"{"alarms":[{"id":"device-offline:ctrl-1","kind":"device-offline","subject":"ctrl-1","text":"device ctrl-1 offline","state":"active-acknowledged","activeSinceMs":1700000000500,"changedMs":1700000000600,"acked":{"by":"ann","atMs":1700000000600,"reason":"seen"}},{"id":"line-faulted:RED","kind":"line-faulted","subject":"RED","text":"RED faulted","state":"active-unacknowledged","activeSinceMs":1700000000300,"changedMs":1700000000500,"shelved":{"by":"ann","atMs":1700000000700,"untilMs":1700003600000,"reason":"seen"}}]}"#;

const T0: u64 = 1_700_000_000_000;

fn at(offset: u64) -> Millis {
    ms(T0 + offset)
}

fn config() -> InterlockConfig {
    let mut config = InterlockConfig::with_resources(["YEL", "RED", "GRN"]);
    config.warn_queued_ms = Some(ms(10_000));
    config
}

#[test]
fn an_interlock_run_writes_the_snapshot_it_wrote_before() {
    let mut lock = Interlock::new(config()).unwrap();
    let load = lock.operation("load");
    let flit = lock.operation("flit");
    let yel = lock.resource_set(&["YEL"]).unwrap();
    let red = lock.resource_set(&["RED"]).unwrap();
    let both = lock.resource_set(&["YEL", "RED"]).unwrap();
    lock.acquire(load, 20, &yel, at(100)).unwrap();
    lock.acquire(flit, 92, &both, at(250)).unwrap();
    lock.fault_resources(&red, Some("estop"), at(300)).unwrap();
    let written = serde_json::to_string(&lock.snapshot(at(400))).unwrap();
    assert_eq!(written, INTERLOCK);
}

#[test]
fn an_old_interlock_snapshot_reads_back_and_writes_the_same_json() {
    let saved: Snapshot = serde_json::from_str(INTERLOCK).unwrap();
    assert_eq!(saved.taken_at_ms, at(400));
    assert_eq!(serde_json::to_string(&saved).unwrap(), INTERLOCK);
    let hand_over = RestoreOptions {
        keep_queue: true,
        keep_holds: true,
    };
    let (restored, grants) = Interlock::restore(config(), &saved, hand_over, at(400)).unwrap();
    assert!(grants.is_empty());
    assert_eq!(
        serde_json::to_string(&restored.snapshot(at(400))).unwrap(),
        INTERLOCK
    );
}

#[test]
fn an_alarm_run_writes_the_snapshot_it_wrote_before() {
    let mut alarms = Alarms::new();
    let mut faulted = Condition::new(AlarmKind::LineFaulted, "RED");
    faulted.since_ms = Some(at(300));
    let conditions = [faulted, Condition::new(AlarmKind::DeviceOffline, "ctrl-1")];
    alarms.observe(&conditions, at(500)).unwrap();
    let ann = Attribution::new(Some("ann"), Some("seen"), false);
    let ids: Vec<String> = alarms.list().map(|a| a.id.clone()).collect();
    alarms.acknowledge(Some(&ids[..1]), &ann, at(600)).unwrap();
    alarms
        .shelve(&ids[1], at(3_600_000), &ann, at(700))
        .unwrap();
    assert_eq!(serde_json::to_string(&alarms.snapshot()).unwrap(), ALARMS);
}

#[test]
fn an_old_alarm_snapshot_reads_back_and_writes_the_same_json() {
    let saved: AlarmsSnapshot = serde_json::from_str(ALARMS).unwrap();
    let restored = Alarms::restore(saved).unwrap();
    assert_eq!(restored.next_expiry_ms(), Some(at(3_600_000)));
    assert_eq!(serde_json::to_string(&restored.snapshot()).unwrap(), ALARMS);
}
