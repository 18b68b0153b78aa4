use super::*;
use serde_json::json;

use crate::time::ms;

fn plant(policy: Policy) -> Interlock {
    let mut config = InterlockConfig::with_resources(["YEL", "GRN", "BLU", "PUR", "RED"]);
    for r in &mut config.resources {
        r.lockout = json!({ "line": r.name, "valves": "close" });
    }
    config.policy = policy;
    config.queue_bound = 4;
    config.warn_queued_ms = Some(ms(1000));
    config.warn_held_ms = Some(ms(5000));
    Interlock::new(config).unwrap()
}

/// A restart whose waiting callers survived (held lines still come back faulted).
const QUEUE_KEPT: RestoreOptions = RestoreOptions {
    keep_queue: true,
    keep_holds: false,
};
const RESTART: RestoreOptions = RestoreOptions {
    keep_queue: false,
    keep_holds: false,
};
const HAND_OVER: RestoreOptions = RestoreOptions {
    keep_queue: true,
    keep_holds: true,
};

fn set(lock: &Interlock, names: &[&str]) -> ResourceSet {
    lock.resource_set(names).unwrap()
}

/// Asks for `names` on behalf of `op`; the call must be accepted (granted or queued).
fn take(lock: &mut Interlock, op: OpId, priority: i32, names: &[&str], at_ms: u64) -> Acquisition {
    let resources = set(lock, names);
    lock.acquire(op, priority, &resources, ms(at_ms)).unwrap()
}

/// 'a' granted YEL at 0 ms and 'b' queued for it at 10 ms.
fn a_holds_yel_and_b_waits() -> (Interlock, [OpId; 2], ResourceSet) {
    let mut lock = plant(Policy::Greedy);
    let [a, b] = ["a", "b"].map(|n| lock.operation(n));
    let yel = set(&lock, &["YEL"]);
    assert_eq!(lock.acquire(a, 1, &yel, ms(0)), Ok(Acquisition::Granted));
    assert_eq!(lock.acquire(b, 2, &yel, ms(10)), Ok(Acquisition::Queued));
    (lock, [a, b], yel)
}

fn counts(holding: usize, queued: usize, faulted: usize) -> Counts {
    Counts {
        holding,
        queued,
        faulted,
    }
}

#[test]
fn grants_free_set_at_once_and_queues_conflicts() {
    let mut lock = plant(Policy::Greedy);
    let load = lock.operation("10");
    let unload = lock.operation("12");
    let yel = set(&lock, &["YEL"]);
    assert_eq!(
        lock.acquire(load, 20, &yel, ms(0)),
        Ok(Acquisition::Granted)
    );
    assert_eq!(
        lock.acquire(unload, 22, &yel, ms(5)),
        Ok(Acquisition::Queued)
    );
    assert_eq!(lock.owner_of(yel.ids()[0]), Some(load));
    assert_eq!(lock.counts(), counts(1, 1, 0));
}

#[test]
fn release_grants_in_priority_then_arrival_order() {
    let mut lock = plant(Policy::Greedy);
    let ops: Vec<OpId> = ["holder", "low", "high", "high-later"]
        .iter()
        .map(|n| lock.operation(n))
        .collect();
    let yel = set(&lock, &["YEL"]);
    lock.acquire(ops[0], 1, &yel, ms(0)).unwrap();
    lock.acquire(ops[1], 5, &yel, ms(1)).unwrap();
    lock.acquire(ops[2], 9, &yel, ms(2)).unwrap();
    lock.acquire(ops[3], 9, &yel, ms(3)).unwrap();
    let grants = lock.release(ops[0], ms(10)).unwrap();
    assert_eq!(grants.len(), 1);
    assert_eq!(grants[0].operation, ops[2]);
    assert_eq!(grants[0].waited_ms, ms(8));
    assert_eq!(lock.release(ops[2], ms(20)).unwrap()[0].operation, ops[3]);
    assert_eq!(lock.release(ops[3], ms(30)).unwrap()[0].operation, ops[1]);
}

#[test]
fn one_release_can_grant_several_requests() {
    let mut lock = plant(Policy::Greedy);
    let wide = lock.operation("wide");
    let a = lock.operation("a");
    let b = lock.operation("b");
    take(&mut lock, wide, 1, &["YEL", "RED"], 0);
    take(&mut lock, a, 5, &["YEL"], 1);
    take(&mut lock, b, 4, &["RED"], 2);
    let granted: Vec<OpId> = lock
        .release(wide, ms(3))
        .unwrap()
        .iter()
        .map(|g| g.operation)
        .collect();
    assert_eq!(granted, vec![a, b]);
}

#[test]
fn greedy_lets_narrow_requests_overtake_a_wide_one_and_no_overtaking_does_not() {
    for (policy, narrow_granted) in [(Policy::Greedy, true), (Policy::NoOvertaking, false)] {
        let mut lock = plant(policy);
        let [holder, flit, load] =
            ["holder", "18 flit downstock", "10 load truck"].map(|n| lock.operation(n));
        take(&mut lock, holder, 1, &["RED"], 0);
        assert_eq!(
            lock.acquire(flit, 92, &set(&lock, &["YEL", "RED"]), ms(1)),
            Ok(Acquisition::Queued)
        );
        let expected = if narrow_granted {
            Acquisition::Granted
        } else {
            Acquisition::Queued
        };
        assert_eq!(
            lock.acquire(load, 20, &set(&lock, &["YEL"]), ms(2)),
            Ok(expected),
            "{policy:?}"
        );
        let grants = lock.release(holder, ms(3)).unwrap();
        let granted: Vec<OpId> = grants.iter().map(|g| g.operation).collect();
        if narrow_granted {
            assert!(granted.is_empty(), "YEL is held by the narrow request");
        } else {
            assert_eq!(granted, vec![flit]);
        }
    }
}

#[test]
fn no_overtaking_still_lets_a_higher_priority_newcomer_in() {
    let mut lock = plant(Policy::NoOvertaking);
    let [holder, low, urgent] = ["holder", "low", "urgent"].map(|n| lock.operation(n));
    take(&mut lock, holder, 1, &["RED"], 0);
    take(&mut lock, low, 5, &["YEL", "RED"], 1);
    assert_eq!(
        lock.acquire(urgent, 50, &set(&lock, &["YEL"]), ms(2)),
        Ok(Acquisition::Granted)
    );
}

#[test]
fn fault_latches_resources_returns_lockouts_and_blocks_until_cleared() {
    let mut lock = plant(Policy::Greedy);
    let [op12, op10] = ["12", "10"].map(|n| lock.operation(n));
    let yel_red = set(&lock, &["YEL", "RED"]);
    lock.acquire(op12, 22, &yel_red, ms(0)).unwrap();
    take(&mut lock, op10, 20, &["YEL"], 1);
    let outcome = lock.fault(op12, Some("timeout"), ms(100)).unwrap();
    let locked: Vec<&str> = outcome
        .lockouts
        .iter()
        .map(|l| lock.resource_name(l.resource).unwrap())
        .collect();
    assert_eq!(locked, vec!["YEL", "RED"]);
    assert_eq!(
        outcome.lockouts[0].command,
        json!({ "line": "YEL", "valves": "close" })
    );
    assert!(
        outcome.grants.is_empty(),
        "a faulted resource is not granted"
    );
    assert!(!lock.is_holding(op12));
    assert_eq!(lock.counts().faulted, 2);
    assert_eq!(
        lock.acquire(op12, 22, &yel_red, ms(150)),
        Ok(Acquisition::Queued),
        "faults block everyone"
    );
    assert_eq!(
        lock.clear(&set(&lock, &["YEL"]), ms(200))
            .unwrap()
            .iter()
            .map(|g| g.operation)
            .collect::<Vec<_>>(),
        vec![op10]
    );
    assert_eq!(
        lock.clear(&set(&lock, &["RED"]), ms(300)).unwrap(),
        vec![],
        "YEL is held by op 10 now"
    );
    assert_eq!(lock.release(op10, ms(400)).unwrap()[0].operation, op12);
}

#[test]
fn fault_while_waiting_drops_the_request() {
    let mut lock = plant(Policy::Greedy);
    let [holder, waiter] = ["holder", "waiter"].map(|n| lock.operation(n));
    take(&mut lock, holder, 1, &["BLU"], 0);
    take(&mut lock, waiter, 2, &["BLU"], 0);
    let outcome = lock.fault(waiter, None, ms(5)).unwrap();
    assert!(outcome.dropped && outcome.lockouts.is_empty());
    assert_eq!(lock.counts(), counts(1, 0, 0));
    assert_eq!(
        lock.fault(waiter, None, ms(6)).unwrap_err().code(),
        "UNKNOWN_OPERATION",
        "an operation that neither holds, waits nor faulted a line has nothing to fault"
    );
}

#[test]
fn an_operation_that_released_or_was_refused_is_unknown_to_a_fault_as_after_a_restart() {
    let mut lock = plant(Policy::Greedy);
    // A refused acquire registers its name and leaves the operation idle.
    let [done, refused] = ["done", "refused"].map(|n| lock.operation(n));
    take(&mut lock, done, 1, &["BLU"], 0);
    lock.release(done, ms(1)).unwrap();
    for op in [done, refused] {
        assert_eq!(
            lock.fault(op, None, ms(2)).unwrap_err().code(),
            "UNKNOWN_OPERATION"
        );
    }
    let (mut restarted, _) =
        Interlock::restore(lock.config().clone(), &lock.snapshot(ms(3)), RESTART, ms(3)).unwrap();
    let again = restarted.operation("done");
    assert_eq!(
        restarted.fault(again, None, ms(4)).unwrap_err().code(),
        "UNKNOWN_OPERATION"
    );
    // Named by a faulted line, it is known: a second fault re-sends its lockouts.
    take(&mut lock, done, 1, &["BLU"], 5);
    lock.fault(done, None, ms(6)).unwrap();
    assert_eq!(lock.fault(done, None, ms(7)).unwrap().lockouts.len(), 1);
}

#[test]
fn repeated_fault_resends_the_same_lockouts() {
    let mut lock = plant(Policy::Greedy);
    let op = lock.operation("op");
    take(&mut lock, op, 1, &["GRN", "RED"], 0);
    let first = lock.fault(op, Some("timeout"), ms(1)).unwrap();
    let second = lock.fault(op, Some("timeout"), ms(2)).unwrap();
    assert_eq!(first.lockouts.len(), 2);
    assert_eq!(second, first);
    assert_eq!(lock.counts().faulted, 2);
}

#[test]
fn emergency_stop_on_a_held_resource_faults_its_whole_operation() {
    let mut lock = plant(Policy::Greedy);
    let [op, other] = ["op", "other"].map(|n| lock.operation(n));
    take(&mut lock, op, 1, &["PUR", "RED"], 0);
    let outcome = lock
        .fault_resources(&set(&lock, &["BLU", "RED"]), Some("e-stop"), ms(1))
        .unwrap();
    let locked: Vec<&str> = outcome
        .lockouts
        .iter()
        .map(|l| lock.resource_name(l.resource).unwrap())
        .collect();
    assert_eq!(locked, vec!["BLU", "PUR", "RED"]);
    assert!(!lock.is_holding(op));
    assert_eq!(lock.release(op, ms(2)).unwrap_err().code(), "NOT_HOLDING");
    assert_eq!(
        lock.acquire(other, 9, &set(&lock, &["PUR"]), ms(3)),
        Ok(Acquisition::Queued),
        "PUR is latched too"
    );
    // A second press re-sends the lockout of what it names.
    assert_eq!(
        lock.fault_resources(&set(&lock, &["RED"]), None, ms(4))
            .unwrap()
            .lockouts
            .len(),
        1
    );
}

#[test]
fn fault_does_not_lock_out_a_resource_cleared_and_reused_meanwhile() {
    let mut lock = plant(Policy::Greedy);
    let [op, other] = ["op", "other"].map(|n| lock.operation(n));
    take(&mut lock, op, 1, &["PUR", "RED"], 0);
    lock.fault_resources(&set(&lock, &["RED"]), None, ms(1))
        .unwrap();
    lock.clear(&set(&lock, &["RED"]), ms(2)).unwrap();
    take(&mut lock, other, 1, &["RED"], 3);
    let outcome = lock.fault(op, None, ms(4)).unwrap();
    let locked: Vec<&str> = outcome
        .lockouts
        .iter()
        .map(|l| lock.resource_name(l.resource).unwrap())
        .collect();
    assert_eq!(locked, vec!["PUR"]);
    assert_eq!(lock.owner_of(lock.resource("RED").unwrap()), Some(other));
}

#[test]
fn cancel_withdraws_a_waiting_request() {
    let mut lock = plant(Policy::NoOvertaking);
    let [holder, wide, narrow] = ["holder", "wide", "narrow"].map(|n| lock.operation(n));
    take(&mut lock, holder, 1, &["RED"], 0);
    take(&mut lock, wide, 9, &["GRN", "RED"], 0);
    take(&mut lock, narrow, 1, &["GRN"], 0);
    let grants = lock.cancel(wide, ms(10)).unwrap();
    assert_eq!(
        grants.iter().map(|g| g.operation).collect::<Vec<_>>(),
        vec![narrow],
        "the reservation on GRN is lifted"
    );
    assert_eq!(
        lock.cancel(wide, ms(11)),
        Err(InterlockError::NotQueued {
            operation: "wide".into()
        })
    );
}

#[test]
fn bad_calls_are_refused_without_changing_state() {
    let mut lock = plant(Policy::Greedy);
    let op = lock.operation("op");
    let yel = set(&lock, &["YEL"]);
    assert_eq!(
        lock.resource_set(&["YEL", "NOPE"]).unwrap_err().code(),
        "UNKNOWN_RESOURCE"
    );
    assert_eq!(
        lock.resource_set::<&str>(&[]).unwrap_err(),
        InterlockError::EmptyResourceSet
    );
    assert_eq!(
        lock.find_operation("ghost").unwrap_err().code(),
        "UNKNOWN_OPERATION"
    );
    assert_eq!(lock.release(op, ms(0)).unwrap_err().code(), "NOT_HOLDING");
    assert_eq!(lock.clear(&yel, ms(0)).unwrap_err().code(), "NOT_FAULTED");
    assert_eq!(
        lock.acquire(OpId::from_bits(99).unwrap(), 1, &yel, ms(0))
            .unwrap_err()
            .code(),
        "UNKNOWN_OPERATION"
    );
    assert_eq!(
        lock.acquire(op, 1, &ResourceSet::default(), ms(0))
            .unwrap_err()
            .code(),
        "EMPTY_RESOURCE_SET"
    );
    lock.acquire(op, 1, &yel, ms(0)).unwrap();
    assert_eq!(
        lock.acquire(op, 1, &yel, ms(0)).unwrap_err().code(),
        "ALREADY_HOLDING"
    );
    let before = lock.snapshot(ms(0));
    for i in 0..4 {
        let waiter = lock.operation(&format!("w{i}"));
        lock.acquire(waiter, 1, &yel, ms(0)).unwrap();
    }
    let w0 = lock.find_operation("w0").unwrap();
    assert_eq!(
        lock.acquire(w0, 1, &yel, ms(0)).unwrap_err().code(),
        "ALREADY_QUEUED"
    );
    let extra = lock.operation("extra");
    assert_eq!(
        lock.acquire(extra, 1, &yel, ms(0)),
        Err(InterlockError::QueueFull { bound: 4 })
    );
    assert!(!lock.is_queued(extra));
    assert_eq!(lock.snapshot(ms(0)).resources, before.resources);
    // Clearing two resources when one is not faulted clears neither.
    lock.fault_resources(&set(&lock, &["GRN"]), None, ms(0))
        .unwrap();
    assert_eq!(
        lock.clear(&set(&lock, &["GRN", "BLU"]), ms(0)).unwrap_err(),
        InterlockError::NotFaulted {
            resource: "BLU".into()
        }
    );
    assert!(lock.is_faulted(lock.resource("GRN").unwrap()));
}

#[test]
fn errors_read_as_instructions() {
    let message = InterlockError::AlreadyHolding {
        operation: "12".into(),
    }
    .to_string();
    assert!(
        message.contains("'12'") && message.contains("C1"),
        "{message}"
    );
    let message = InterlockError::UnknownResource { name: "YLW".into() }.to_string();
    assert!(message.contains("'YLW'"), "{message}");
}

#[test]
fn invalid_configs_are_refused() {
    let cases = [
        (
            InterlockConfig::with_resources(Vec::<String>::new()),
            "no resources",
        ),
        (InterlockConfig::with_resources(["YEL", "YEL"]), "twice"),
        (InterlockConfig::with_resources([" "]), "empty name"),
        (
            InterlockConfig {
                queue_bound: 0,
                ..InterlockConfig::with_resources(["A"])
            },
            "queue bound",
        ),
        (
            InterlockConfig {
                warn_held_ms: Some(ms(0)),
                ..InterlockConfig::with_resources(["A"])
            },
            "positive",
        ),
    ];
    for (config, needle) in cases {
        let err = Interlock::new(config).unwrap_err();
        assert_eq!(err.code(), "INVALID_CONFIG");
        assert!(err.to_string().contains(needle), "{err}");
    }
}

#[test]
fn config_reads_from_json_with_defaults() {
    let config: InterlockConfig = serde_json::from_value(json!({
        "resources": [{ "name": "YEL", "lockout": { "valves": { "V1": 0 } } }],
        "policy": "no-overtaking",
        "warnQueuedMs": 30000
    }))
    .unwrap();
    assert_eq!(config.policy, Policy::NoOvertaking);
    assert_eq!(config.queue_bound, DEFAULT_QUEUE_BOUND);
    assert_eq!(config.warn_queued_ms, Some(ms(30000)));
    assert!(config.record_events);
    let typo =
        serde_json::from_value::<InterlockConfig>(json!({ "resources": [], "polcy": "greedy" }));
    assert!(typo.unwrap_err().to_string().contains("polcy"));
}

#[test]
fn tick_warns_once_per_crossing_at_the_threshold() {
    let mut lock = plant(Policy::Greedy);
    let [holder, waiter] = ["holder", "waiter"].map(|n| lock.operation(n));
    take(&mut lock, holder, 1, &["YEL"], 0);
    take(&mut lock, waiter, 1, &["YEL"], 0);
    assert!(lock.tick(ms(999)).is_empty());
    let warnings = lock.tick(ms(1000));
    assert_eq!(warnings.len(), 1);
    assert_eq!(
        (
            warnings[0].kind(),
            warnings[0].operation(),
            warnings[0].waited_ms()
        ),
        (EventKind::WarnQueued, Some(waiter), Some(ms(1000)))
    );
    assert!(lock.tick(ms(1500)).is_empty(), "once per crossing");
    let held = lock.tick(ms(5000));
    assert_eq!(
        held.iter().map(|w| w.kind()).collect::<Vec<_>>(),
        vec![EventKind::WarnHeld]
    );
    lock.release(holder, ms(5001)).unwrap();
    lock.release(waiter, ms(5002)).unwrap();
    take(&mut lock, waiter, 1, &["YEL"], 6000);
    assert_eq!(lock.tick(ms(11000)).len(), 1, "a new hold warns again");
}

#[test]
fn every_state_change_yields_an_event() {
    let (mut lock, [a, b], yel) = a_holds_yel_and_b_waits();
    lock.release(a, ms(50)).unwrap();
    lock.fault(b, Some("no flow"), ms(80)).unwrap();
    lock.clear(&yel, ms(90)).unwrap();
    let records: Vec<EventRecord> = lock
        .drain_events()
        .iter()
        .map(|e| lock.describe(e))
        .collect();
    let kinds: Vec<EventKind> = records.iter().map(|r| r.kind).collect();
    use EventKind::*;
    assert_eq!(
        kinds,
        vec![Granted, Queued, Released, Granted, Faulted, Cleared]
    );
    assert_eq!(records[3].operation.as_deref(), Some("b"));
    assert_eq!(records[3].waited_ms, Some(ms(40)));
    assert_eq!(records[2].held_ms, Some(ms(50)));
    assert_eq!(records[4].held_ms, Some(ms(30)));
    assert_eq!(records[4].note.as_deref(), Some("no flow"));
    assert_eq!(records[5].resources, vec!["YEL".to_string()]);
    assert!(lock.drain_events().is_empty());
}

#[test]
fn event_records_keep_their_json_shape() {
    let (mut lock, [_, b], yel) = a_holds_yel_and_b_waits();
    lock.cancel(b, ms(20)).unwrap();
    lock.fault_resources_by(
        &yel,
        Some("smoke"),
        &Attribution::new(Some("ann"), Some("drill"), false),
        ms(30),
    )
    .unwrap();
    lock.clear_checked(
        &yel,
        &Attribution::new(Some("bob"), None, true),
        |_| Vec::new(),
        ms(40),
    )
    .unwrap();
    let records: Vec<serde_json::Value> = lock
        .drain_events()
        .iter()
        .map(|e| serde_json::to_value(lock.describe(e)).unwrap())
        .collect();
    assert_eq!(
        records,
        [
            json!({ "atMs": 0, "kind": "granted", "operation": "a", "priority": 1, "resources": ["YEL"], "waitedMs": 0 }),
            json!({ "atMs": 10, "kind": "queued", "operation": "b", "priority": 2, "resources": ["YEL"] }),
            json!({ "atMs": 20, "kind": "cancelled", "operation": "b", "priority": 2, "resources": ["YEL"], "waitedMs": 10 }),
            json!({ "atMs": 30, "kind": "faulted", "operation": "a", "priority": 1, "resources": ["YEL"], "heldMs": 30, "note": "smoke" }),
            json!({ "atMs": 30, "kind": "resource-faulted", "resources": ["YEL"], "note": "smoke", "by": "ann", "reason": "drill" }),
            // Forced with nothing to override is an ordinary clear.
            json!({ "atMs": 40, "kind": "cleared", "resources": ["YEL"], "by": "bob" }),
        ]
    );
}

#[test]
fn events_can_be_switched_off() {
    let mut config = InterlockConfig::with_resources(["A"]);
    config.record_events = false;
    let mut lock = Interlock::new(config).unwrap();
    let op = lock.operation("op");
    lock.acquire(op, 1, &lock.resource_set(&["A"]).unwrap(), ms(0))
        .unwrap();
    assert!(!lock.has_events());
}

#[test]
fn restore_faults_what_was_held_and_keeps_faults_and_queue() {
    let mut lock = plant(Policy::Greedy);
    let [a, b, c] = ["a", "b", "c"].map(|n| lock.operation(n));
    take(&mut lock, a, 1, &["YEL"], 0);
    take(&mut lock, b, 5, &["YEL", "GRN"], 1);
    take(&mut lock, c, 2, &["BLU"], 2);
    lock.fault(c, Some("dry pump"), ms(3)).unwrap();
    let snapshot = lock.snapshot(ms(10));
    let json = serde_json::to_string(&snapshot).unwrap();
    let parsed: Snapshot = serde_json::from_str(&json).unwrap();
    let (mut restored, grants) =
        Interlock::restore(lock.config().clone(), &parsed, QUEUE_KEPT, ms(20)).unwrap();
    assert!(grants.is_empty());
    let yel = restored.resource("YEL").unwrap();
    assert!(restored.is_faulted(yel), "held when saved: interrupted");
    assert!(
        restored.is_faulted(restored.resource("BLU").unwrap()),
        "faults stay faulted"
    );
    let b2 = restored.find_operation("b").unwrap();
    assert!(restored.is_queued(b2));
    assert!(!restored.is_holding(restored.find_operation("a").unwrap()));
    let after = restored.snapshot(ms(20));
    assert!(after.holds.is_empty());
    assert_eq!(after.queue, snapshot.queue);
    match &after.resources[0].state {
        ResourceState::Faulted(f) => {
            assert_eq!(f.cause, FaultCause::Interrupted);
            assert_eq!(f.operation.as_deref(), Some("a"));
        }
        other => panic!("YEL restored as {other:?}"),
    }
    let kinds: Vec<EventKind> = restored.drain_events().iter().map(|e| e.kind()).collect();
    assert_eq!(kinds, vec![EventKind::Interrupted]);
    // The interrupted line clears like any fault and the waiter goes through.
    let grants = restored
        .clear(&restored.resource_set(&["YEL"]).unwrap(), ms(30))
        .unwrap();
    assert_eq!(grants[0].operation, b2);
}

#[test]
fn restore_under_a_changed_config_drops_what_no_longer_exists() {
    let mut lock = plant(Policy::Greedy);
    let [a, b] = ["a", "b"].map(|n| lock.operation(n));
    take(&mut lock, a, 1, &["RED"], 0);
    take(&mut lock, b, 1, &["RED", "YEL"], 0);
    let snapshot = lock.snapshot(ms(1));
    let (mut restored, _) = Interlock::restore(
        InterlockConfig::with_resources(["YEL", "GRN"]),
        &snapshot,
        QUEUE_KEPT,
        ms(2),
    )
    .unwrap();
    assert_eq!(restored.counts(), Counts::default());
    let notes: Vec<String> = restored
        .drain_events()
        .into_iter()
        .filter_map(|e| e.note().map(str::to_owned))
        .collect();
    assert!(notes.iter().any(|n| n.contains("'RED'")), "{notes:?}");
    let bad = Snapshot {
        version: 99,
        ..snapshot
    };
    assert_eq!(
        Interlock::restore(lock.config().clone(), &bad, QUEUE_KEPT, ms(0))
            .unwrap_err()
            .code(),
        "INVALID_SNAPSHOT"
    );
}

#[test]
fn restore_without_queue_drops_waiters_whose_callers_are_gone() {
    let mut lock = plant(Policy::Greedy);
    let [a, b] = ["a", "b"].map(|n| lock.operation(n));
    take(&mut lock, a, 1, &["GRN"], 0);
    take(&mut lock, b, 1, &["GRN"], 0);
    let (mut restored, grants) =
        Interlock::restore(lock.config().clone(), &lock.snapshot(ms(1)), RESTART, ms(2)).unwrap();
    assert!(grants.is_empty());
    assert_eq!(restored.counts(), counts(0, 0, 1));
    let kinds: Vec<EventKind> = restored.drain_events().iter().map(|e| e.kind()).collect();
    assert_eq!(kinds, vec![EventKind::Interrupted, EventKind::Dropped]);
}

/// YEL+GRN held by 'a', 'b' waiting on YEL, BLU faulted under 'c'; PUR and RED free.
fn saved_plant() -> (Interlock, Snapshot) {
    let mut lock = plant(Policy::Greedy);
    let [a, b, c] = ["a", "b", "c"].map(|n| lock.operation(n));
    take(&mut lock, a, 1, &["YEL", "GRN"], 0);
    take(&mut lock, b, 5, &["YEL"], 1);
    take(&mut lock, c, 2, &["BLU"], 2);
    lock.fault(c, Some("dry pump"), ms(3)).unwrap();
    let snapshot = lock.snapshot(ms(10));
    (lock, snapshot)
}

fn request(operation: &str, resources: &[&str]) -> RequestSnapshot {
    RequestSnapshot {
        operation: operation.into(),
        priority: 1,
        resources: resources.iter().map(|r| r.to_string()).collect(),
        since_ms: ms(0),
        waited_ms: ms(0),
    }
}

fn line(snapshot: &mut Snapshot, name: &str) -> usize {
    snapshot
        .resources
        .iter()
        .position(|r| r.name == name)
        .unwrap()
}

#[test]
fn snapshot_v2_lists_the_configured_lines_in_config_order() {
    let (_, snapshot) = saved_plant();
    assert_eq!(snapshot.version, 2);
    assert_eq!(snapshot.configured, ["YEL", "GRN", "BLU", "PUR", "RED"]);
    let json = serde_json::to_value(&snapshot).unwrap();
    assert_eq!(
        json["configured"],
        json!(["YEL", "GRN", "BLU", "PUR", "RED"])
    );
}

#[test]
fn restore_refuses_a_snapshot_that_contradicts_itself_and_names_the_entry() {
    type Mutation = fn(&mut Snapshot);
    let cases: Vec<(&str, Mutation, &[&str])> = vec![
        ("unknown version", |s| s.version = 3, &["version 3"]),
        (
            "v2 without configured",
            |s| s.configured.clear(),
            &["'configured' is missing or empty"],
        ),
        (
            "v1 with configured",
            |s| s.version = 1,
            &["version 1", "'configured'"],
        ),
        (
            "configured twice",
            |s| s.configured.push("YEL".into()),
            &["'YEL'", "twice in 'configured'"],
        ),
        (
            "configured empty name",
            |s| s.configured.push(" ".into()),
            &["empty name"],
        ),
        (
            "line listed twice",
            |s| {
                let pur = s.resources[3].clone();
                s.resources.push(pur);
            },
            &["'PUR'", "twice in 'resources'"],
        ),
        (
            "unknown entry",
            |s| {
                s.resources.push(ResourceSnapshot {
                    name: "ORANGE".into(),
                    state: ResourceState::Free,
                })
            },
            &[
                "resources[5]",
                "'ORANGE'",
                "not among the snapshot's configured lines",
            ],
        ),
        (
            "omitted line",
            |s| {
                let blu = line(s, "BLU");
                s.resources.remove(blu);
            },
            &["'BLU'", "does not say its state"],
        ),
        (
            "hold on a line its operation does not own",
            |s| s.holds[0].resources.push("PUR".into()),
            &["holds[0]", "'a'", "'PUR'", "free"],
        ),
        (
            "hold on a faulted line",
            |s| s.holds[0].resources.push("BLU".into()),
            &["holds[0]", "'a'", "'BLU'", "faulted"],
        ),
        (
            "hold on a line held by another operation",
            |s| {
                let red = line(s, "RED");
                s.resources[red].state = ResourceState::Held {
                    operation: "z".into(),
                };
                s.holds[0].resources.push("RED".into());
            },
            &["holds[0]", "'a'", "'RED'", "held by operation 'z'"],
        ),
        (
            "held line with no hold",
            |s| {
                let red = line(s, "RED");
                s.resources[red].state = ResourceState::Held {
                    operation: "z".into(),
                };
            },
            &["'RED'", "'z'", "no hold"],
        ),
        (
            "held line missing from its operation's hold",
            |s| s.holds[0].resources.retain(|r| r != "GRN"),
            &["'GRN'", "'a'", "no hold"],
        ),
        (
            "operation holding twice",
            |s| {
                let again = s.holds[0].clone();
                s.holds.push(again);
            },
            &["'a'", "holds twice", "holds[1]"],
        ),
        (
            "operation waiting twice",
            |s| {
                let again = s.queue[0].clone();
                s.queue.push(again);
            },
            &["'b'", "waits twice", "queue[1]"],
        ),
        (
            "operation holding and waiting",
            |s| s.queue.push(request("a", &["RED"])),
            &["'a'", "both holds and waits", "queue[1]"],
        ),
        (
            "hold names a line not configured",
            |s| s.holds[0].resources.push("ORANGE".into()),
            &[
                "holds[0]",
                "'a'",
                "'ORANGE'",
                "not among the snapshot's configured lines",
            ],
        ),
        (
            "waiting request names a line not configured",
            |s| s.queue[0].resources = vec!["ORANGE".into()],
            &[
                "queue[0]",
                "'b'",
                "'ORANGE'",
                "not among the snapshot's configured lines",
            ],
        ),
        (
            "waiting request names a line twice",
            |s| s.queue[0].resources = vec!["RED".into(), "RED".into()],
            &["queue[0]", "'RED'", "twice"],
        ),
        (
            "waiting request names no line",
            |s| s.queue[0].resources.clear(),
            &["queue[0]", "'b'", "names no line"],
        ),
        (
            "hold names no operation",
            |s| s.holds[0].operation = "".into(),
            &["holds[0]", "names no operation"],
        ),
        (
            "fault under an empty operation name",
            |s| {
                let blu = line(s, "BLU");
                if let ResourceState::Faulted(f) = &mut s.resources[blu].state {
                    f.operation = Some("".into());
                }
            },
            &["'BLU'", "empty name"],
        ),
    ];
    let (lock, valid) = saved_plant();
    for (what, mutate, needles) in cases {
        let mut snapshot = valid.clone();
        mutate(&mut snapshot);
        for options in [RESTART, QUEUE_KEPT, HAND_OVER] {
            let err = Interlock::restore(lock.config().clone(), &snapshot, options, ms(20))
                .map(|_| ())
                .unwrap_err();
            assert_eq!(err.code(), "INVALID_SNAPSHOT", "{what}");
            let message = err.to_string();
            for needle in needles {
                assert!(message.contains(needle), "{what}: {message}");
            }
            assert!(message.contains("nothing was restored"), "{message}");
        }
    }
}

#[test]
fn a_refusal_quotes_little_of_a_long_name() {
    let (lock, mut snapshot) = saved_plant();
    snapshot.resources.push(ResourceSnapshot {
        name: "X".repeat(5000),
        state: ResourceState::Free,
    });
    let message = Interlock::restore(lock.config().clone(), &snapshot, RESTART, ms(20))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(message.len() < 400, "{} characters", message.len());
    assert!(message.contains("XXX\u{2026}'"), "{message}");
}

#[test]
fn a_legacy_v1_snapshot_restores_with_its_listed_lines_as_configured() {
    let (lock, snapshot) = saved_plant();
    let legacy = Snapshot {
        version: 1,
        configured: Vec::new(),
        ..snapshot.clone()
    };
    let json = serde_json::to_value(&legacy).unwrap();
    let v1: Snapshot = serde_json::from_value(json!({
        "version": 1,
        "takenAtMs": json["takenAtMs"],
        "resources": json["resources"],
        "queue": json["queue"],
        "holds": json["holds"],
    }))
    .unwrap();
    assert_eq!(v1, legacy, "a v1 document has no 'configured' key");
    let (from_v1, _) = Interlock::restore(lock.config().clone(), &v1, QUEUE_KEPT, ms(20)).unwrap();
    let (from_v2, _) =
        Interlock::restore(lock.config().clone(), &snapshot, QUEUE_KEPT, ms(20)).unwrap();
    assert_eq!(from_v1.snapshot(ms(30)), from_v2.snapshot(ms(30)));
}

#[test]
fn lines_new_since_the_save_start_free_with_an_event() {
    let mut lock = Interlock::new(InterlockConfig::with_resources(["YEL", "GRN"])).unwrap();
    let a = lock.operation("a");
    take(&mut lock, a, 1, &["GRN"], 0);
    let snapshot = lock.snapshot(ms(1));
    let (mut restored, grants) = Interlock::restore(
        InterlockConfig::with_resources(["BLU", "YEL", "GRN"]),
        &snapshot,
        RESTART,
        ms(2),
    )
    .unwrap();
    assert!(grants.is_empty());
    let blu = restored.resource("BLU").unwrap();
    assert!(!restored.is_faulted(blu) && restored.owner_of(blu).is_none());
    assert!(restored.is_faulted(restored.resource("GRN").unwrap()));
    let records: Vec<EventRecord> = restored
        .drain_events()
        .iter()
        .map(|e| restored.describe(e))
        .collect();
    let added: Vec<&EventRecord> = records
        .iter()
        .filter(|r| r.kind == EventKind::ResourceAdded)
        .collect();
    assert_eq!(added.len(), 1, "{records:?}");
    assert_eq!(added[0].resources, ["BLU"]);
    assert!(added[0].note.as_deref().unwrap().contains("starts free"));
    assert_eq!(
        serde_json::to_value(EventKind::ResourceAdded).unwrap(),
        json!("resource-added")
    );
}

#[test]
fn lines_no_longer_configured_are_dropped_with_an_event_each() {
    let (_, snapshot) = saved_plant();
    let (mut restored, _) = Interlock::restore(
        InterlockConfig::with_resources(["YEL", "GRN", "BLU"]),
        &snapshot,
        RESTART,
        ms(20),
    )
    .unwrap();
    let notes: Vec<String> = restored
        .drain_events()
        .into_iter()
        .filter(|e| e.kind() == EventKind::Interrupted && e.operation().is_none())
        .filter_map(|e| e.note().map(str::to_owned))
        .collect();
    assert_eq!(notes.len(), 2, "{notes:?}");
    assert!(
        notes[0].contains("'PUR'") && notes[1].contains("'RED'"),
        "{notes:?}"
    );
}

#[test]
fn a_hand_over_keeps_holds_with_their_start() {
    let mut lock = plant(Policy::Greedy);
    let [a, b, c] = ["a", "b", "c"].map(|n| lock.operation(n));
    take(&mut lock, b, 1, &["YEL"], 0);
    take(&mut lock, a, 3, &["YEL", "GRN"], 60);
    lock.release(b, ms(100)).unwrap();
    take(&mut lock, c, 2, &["RED"], 120);
    take(&mut lock, b, 1, &["RED"], 130);
    let snapshot = lock.snapshot(ms(200));

    let (mut same, grants) =
        Interlock::restore(lock.config().clone(), &snapshot, HAND_OVER, ms(250)).unwrap();
    assert!(grants.is_empty());
    assert!(!same.has_events(), "nothing changed");
    let after = same.snapshot(ms(200));
    assert_eq!(after.resources, snapshot.resources);
    assert_eq!(after.queue, snapshot.queue);
    let mut holds = after.holds.clone();
    holds.sort_by(|x, y| x.operation.cmp(&y.operation));
    assert_eq!(holds, snapshot.holds);
    assert_eq!((holds[0].since_ms, holds[0].waited_ms), (ms(100), ms(40)));
    let a2 = same.find_operation("a").unwrap();
    assert!(same.is_holding(a2));
    same.release(a2, ms(300)).unwrap();
    let released = same.drain_events().pop().unwrap();
    assert_eq!(
        released.held_ms(),
        Some(ms(200)),
        "held since 100, not since the hand-over"
    );

    // GRN is gone: 'a' lost part of its line, so what remains of it is faulted.
    let (mut changed, _) = Interlock::restore(
        InterlockConfig::with_resources(["YEL", "BLU", "PUR", "RED"]),
        &snapshot,
        HAND_OVER,
        ms(250),
    )
    .unwrap();
    let yel = changed.resource("YEL").unwrap();
    assert!(changed.is_faulted(yel));
    assert!(!changed.is_holding(changed.find_operation("a").unwrap()));
    let c2 = changed.find_operation("c").unwrap();
    assert_eq!(changed.owner_of(changed.resource("RED").unwrap()), Some(c2));
    assert!(changed.is_queued(changed.find_operation("b").unwrap()));
    match &changed.snapshot(ms(250)).resources[0].state {
        ResourceState::Faulted(f) => {
            assert_eq!(f.cause, FaultCause::Interrupted);
            assert_eq!(f.operation.as_deref(), Some("a"));
            assert!(f.note.as_deref().unwrap().contains("'GRN'"), "{f:?}");
            assert_eq!(f.since_ms, ms(250));
        }
        other => panic!("YEL restored as {other:?}"),
    }
    let interrupted: Vec<Event> = changed
        .drain_events()
        .into_iter()
        .filter(|e| e.kind() == EventKind::Interrupted && e.operation().is_some())
        .collect();
    assert_eq!(interrupted.len(), 1);
    assert_eq!(changed.names(interrupted[0].resources()), ["YEL"]);
}

#[test]
fn a_restart_faults_every_held_line_whatever_the_hand_over_would_keep() {
    let (lock, snapshot) = saved_plant();
    let (restored, _) =
        Interlock::restore(lock.config().clone(), &snapshot, RESTART, ms(20)).unwrap();
    assert_eq!(restored.counts(), counts(0, 0, 3));
    let (kept, _) =
        Interlock::restore(lock.config().clone(), &snapshot, HAND_OVER, ms(20)).unwrap();
    assert_eq!(kept.counts(), counts(1, 1, 1));
}

#[test]
fn dropping_a_waiter_on_a_removed_line_lets_the_one_behind_it_go() {
    let mut lock = plant(Policy::NoOvertaking);
    let [holder, wide, narrow] = ["holder", "wide", "narrow"].map(|n| lock.operation(n));
    take(&mut lock, holder, 1, &["RED"], 0);
    take(&mut lock, wide, 9, &["GRN", "RED"], 1);
    take(&mut lock, narrow, 1, &["GRN"], 2);
    let (restored, grants) = Interlock::restore(
        InterlockConfig {
            policy: Policy::NoOvertaking,
            ..InterlockConfig::with_resources(["YEL", "GRN"])
        },
        &lock.snapshot(ms(3)),
        HAND_OVER,
        ms(4),
    )
    .unwrap();
    assert_eq!(grants.len(), 1);
    assert_eq!(restored.operation_name(grants[0].operation), Some("narrow"));
    assert_eq!(grants[0].waited_ms, ms(2));
}

#[test]
fn unknown_state_faults_every_line_until_cleared() {
    let config = plant(Policy::Greedy).config().clone();
    let note = "state unknown after restart: the saved state file is empty";
    let mut lock = Interlock::unknown_state(config, note, ms(5)).unwrap();
    assert_eq!(lock.counts().faulted, 5);
    let snapshot = lock.snapshot(ms(6));
    for entry in &snapshot.resources {
        assert_eq!(
            entry.state,
            ResourceState::Faulted(FaultSnapshot {
                cause: FaultCause::Unknown,
                operation: None,
                note: Some(note.into()),
                since_ms: ms(5),
            }),
            "{}",
            entry.name
        );
    }
    assert_eq!(
        serde_json::to_value(&snapshot).unwrap()["resources"][0]["state"]["cause"],
        json!("unknown")
    );
    let records: Vec<EventRecord> = lock
        .drain_events()
        .iter()
        .map(|e| lock.describe(e))
        .collect();
    assert_eq!(records.len(), 1);
    assert_eq!(records[0].kind, EventKind::StateUnknown);
    assert_eq!(records[0].resources.len(), 5);
    assert_eq!(records[0].note.as_deref(), Some(note));
    assert_eq!(
        serde_json::to_value(EventKind::StateUnknown).unwrap(),
        json!("state-unknown")
    );

    // Saved again, the unknown state survives a restart.
    let (restored, _) =
        Interlock::restore(lock.config().clone(), &snapshot, RESTART, ms(7)).unwrap();
    assert_eq!(restored.snapshot(ms(6)).resources, snapshot.resources);

    let op = lock.operation("op");
    let yel = set(&lock, &["YEL"]);
    assert_eq!(lock.acquire(op, 1, &yel, ms(8)), Ok(Acquisition::Queued));
    let grants = lock.clear(&yel, ms(9)).unwrap();
    assert_eq!(grants[0].operation, op);
    lock.clear(&lock.faulted_resources(), ms(10)).unwrap();
    assert_eq!(lock.counts(), counts(1, 0, 0));
    let quiet = Interlock::unknown_state(lock.config().clone(), "  ", ms(0)).unwrap();
    assert!(matches!(
        &quiet.snapshot(ms(0)).resources[0].state,
        ResourceState::Faulted(f) if f.note.is_none()
    ));
}

fn note_of(lock: &Interlock, line: &str) -> String {
    let snapshot = lock.snapshot(ms(0));
    let entry = snapshot.resources.iter().find(|r| r.name == line).unwrap();
    match &entry.state {
        ResourceState::Faulted(f) => f.note.clone().unwrap(),
        other => panic!("{line} is {other:?}"),
    }
}

#[test]
fn fault_notes_are_kept_to_a_bounded_length() {
    let mut lock = plant(Policy::Greedy);
    let [a, b] = ["a", "b"].map(|n| lock.operation(n));
    take(&mut lock, a, 1, &["YEL"], 0);
    take(&mut lock, b, 1, &["GRN"], 0);
    let stack = "é".repeat(3000);
    lock.fault(a, Some(&stack), ms(1)).unwrap();
    let kept = note_of(&lock, "YEL");
    assert_eq!(kept.chars().count(), NOTE_MAX_CHARS);
    assert!(kept.ends_with('\u{2026}'));
    assert!(stack.starts_with(kept.trim_end_matches('\u{2026}')));
    let faulted = lock
        .drain_events()
        .into_iter()
        .find(|e| e.kind() == EventKind::Faulted)
        .unwrap();
    assert_eq!(faulted.note(), Some(kept.as_str()));

    lock.fault_resources(&set(&lock, &["GRN", "RED"]), Some(&"x".repeat(501)), ms(2))
        .unwrap();
    assert_eq!(note_of(&lock, "RED").chars().count(), NOTE_MAX_CHARS);
    assert_eq!(note_of(&lock, "GRN").chars().count(), NOTE_MAX_CHARS);
    let exact = "y".repeat(NOTE_MAX_CHARS);
    lock.fault_resources(&set(&lock, &["BLU"]), Some(&exact), ms(3))
        .unwrap();
    assert_eq!(
        note_of(&lock, "BLU"),
        exact,
        "a note at the bound is kept whole"
    );

    let mut snapshot = lock.snapshot(ms(4));
    assert_eq!(snapshot.resources[3].name, "PUR");
    assert_eq!(snapshot.resources[3].state, ResourceState::Free);
    snapshot.resources[3].state = ResourceState::Faulted(FaultSnapshot {
        cause: FaultCause::Manual,
        operation: None,
        note: Some("z".repeat(100_000)),
        since_ms: ms(4),
    });
    let (restored, _) =
        Interlock::restore(lock.config().clone(), &snapshot, RESTART, ms(5)).unwrap();
    assert_eq!(note_of(&restored, "PUR").chars().count(), NOTE_MAX_CHARS);
    assert_eq!(note_of(&restored, "YEL"), kept);
}

#[test]
fn names_that_share_a_recent_slot_or_a_reused_slot_each_find_their_own_operation() {
    let mut lock = plant(Policy::Greedy);
    let first = "op0".to_owned();
    let twin = (1..)
        .map(|i| format!("op{i}"))
        .find(|n| recent_slot(n) == recent_slot(&first))
        .unwrap();
    let (a, b) = (lock.operation(&first), lock.operation(&twin));
    assert_ne!(a, b);
    let yel = set(&lock, &["YEL"]);
    let grn = set(&lock, &["GRN"]);
    lock.acquire(a, 1, &yel, ms(0)).unwrap();
    lock.acquire(b, 1, &grn, ms(0)).unwrap();
    // Each lookup evicts the other from the shared slot.
    assert_eq!(lock.operation(&first), a);
    assert_eq!(lock.operation(&twin), b);
    lock.release_named(&first, ms(1)).unwrap();
    assert!(lock.is_holding(b) && !lock.is_holding(a));
    lock.release_named(&twin, ms(2)).unwrap();

    // A forgotten name's slot taken by another name: the old name holds nothing.
    let mut lock = keeping_names(plant(Policy::Greedy), 1);
    let old = lock.operation("old");
    assert_eq!(
        lock.release_named("old", ms(0)).unwrap_err().code(),
        "NOT_HOLDING"
    );
    let new = lock.operation("new");
    assert_eq!(new.index, old.index, "the slot is reused");
    lock.acquire(new, 1, &set(&lock, &["YEL"]), ms(1)).unwrap();
    assert_eq!(
        lock.release_named("old", ms(2)).unwrap_err().code(),
        "NOT_HOLDING"
    );
    assert!(lock.is_holding(new));
}

#[test]
fn release_and_cancel_by_name_do_not_register_unknown_names() {
    let mut lock = plant(Policy::Greedy);
    assert_eq!(
        lock.release_named("ghost", ms(0)),
        Err(InterlockError::NotHolding {
            operation: "ghost".into()
        })
    );
    assert_eq!(
        lock.cancel_named("ghost", ms(0)),
        Err(InterlockError::NotQueued {
            operation: "ghost".into()
        })
    );
    assert!(lock.find_operation("ghost").is_err(), "not registered");
    let long = "g".repeat(10_000);
    let message = lock.release_named(&long, ms(0)).unwrap_err().to_string();
    assert!(message.len() < 300, "{message}");

    let [a, b] = ["a", "b"].map(|n| lock.operation(n));
    let yel = set(&lock, &["YEL"]);
    lock.acquire(a, 1, &yel, ms(0)).unwrap();
    lock.acquire(b, 1, &yel, ms(1)).unwrap();
    assert_eq!(
        lock.release_named("b", ms(2)).unwrap_err().code(),
        "NOT_HOLDING"
    );
    assert_eq!(
        lock.cancel_named("a", ms(2)).unwrap_err().code(),
        "NOT_QUEUED"
    );
    assert_eq!(lock.release_named("a", ms(3)).unwrap()[0].operation, b);
    assert_eq!(
        lock.cancel_named("b", ms(4)).unwrap_err().code(),
        "NOT_QUEUED"
    );
    let c = lock.operation("c");
    lock.acquire(c, 1, &yel, ms(5)).unwrap();
    assert_eq!(lock.cancel_named("c", ms(6)), Ok(vec![]));
    assert!(!lock.is_queued(c));
}

// ---- forgetting idle operation names ---------------------------------------

/// An interlock that starts forgetting idle names past `kept` instead of
/// [`OPERATION_NAMES_KEPT`].
fn keeping_names(mut lock: Interlock, kept: usize) -> Interlock {
    lock.names_kept = kept;
    lock.forget_at = kept;
    lock
}

#[test]
fn a_new_name_per_msg_does_not_grow_the_interlock() {
    let mut lock = plant(Policy::Greedy);
    let yel = set(&lock, &["YEL"]);
    for i in 0..3 * OPERATION_NAMES_KEPT {
        let op = lock.operation(&format!("batch-{i}"));
        assert_eq!(
            lock.acquire(op, 1, &yel, ms(i as u64)),
            Ok(Acquisition::Granted)
        );
        lock.release(op, ms(i as u64)).unwrap();
        lock.drain_events();
    }
    assert!(lock.known_operations() <= OPERATION_NAMES_KEPT);
    assert!(lock.operations.len() <= OPERATION_NAMES_KEPT);
    assert_eq!(lock.forgettings(), 2);
}

#[test]
fn a_forgotten_handle_is_refused_even_once_its_slot_is_reused() {
    let mut lock = keeping_names(plant(Policy::Greedy), 2);
    let yel = set(&lock, &["YEL"]);
    let old = lock.operation("old");
    lock.operation("other");
    let newer = lock.operation("newer"); // forgets "old" and "other", reuses a slot
    assert_eq!(newer.index(), old.index());
    assert_eq!(lock.forgettings(), 1);
    assert_eq!(lock.operation_name(old), None);
    assert_eq!(
        lock.acquire(old, 1, &yel, ms(0)).unwrap_err().code(),
        "UNKNOWN_OPERATION"
    );
    assert!(!lock.is_holding(newer));
    assert_eq!(
        lock.acquire(newer, 1, &yel, ms(0)),
        Ok(Acquisition::Granted)
    );
    assert!(
        !lock.is_holding(old),
        "the old handle never stands for the new name"
    );
    assert_ne!(lock.operation("old"), old, "the name registers anew");
}

#[test]
fn busy_and_faulted_operations_and_undrained_events_keep_their_names() {
    let mut lock = keeping_names(plant(Policy::Greedy), 1);
    let (yel, grn) = (set(&lock, &["YEL"]), set(&lock, &["GRN"]));
    let holder = lock.operation("holder");
    lock.acquire(holder, 1, &yel, ms(0)).unwrap();
    let waiter = lock.operation("waiter");
    lock.acquire(waiter, 1, &yel, ms(0)).unwrap();
    let faulted = lock.operation("faulted");
    lock.acquire(faulted, 1, &grn, ms(0)).unwrap();
    lock.fault(faulted, Some("stuck"), ms(1)).unwrap();
    lock.drain_events();
    let evented = lock.operation("evented");
    take(&mut lock, evented, 1, &["BLU"], 2);
    lock.release(evented, ms(3)).unwrap(); // its events are not drained yet
    for i in 0..10 {
        lock.operation(&format!("passer-{i}"));
    }
    assert!(lock.forgettings() > 0);
    for (op, name) in [
        (holder, "holder"),
        (waiter, "waiter"),
        (faulted, "faulted"),
        (evented, "evented"),
    ] {
        assert_eq!(lock.operation_name(op), Some(name));
        assert_eq!(lock.find_operation(name), Ok(op));
    }
    let records: Vec<_> = lock
        .drain_events()
        .iter()
        .map(|e| lock.describe(e))
        .collect();
    assert!(records
        .iter()
        .all(|r| r.operation.as_deref() == Some("evented")));
    let snapshot = lock.snapshot(ms(4));
    let grn_state = &snapshot.resources[1].state;
    assert!(
        matches!(grn_state, ResourceState::Faulted(f) if f.operation.as_deref() == Some("faulted"))
    );
    // Once cleared and drained, the faulted operation may be forgotten too.
    lock.clear(&grn, ms(5)).unwrap();
    lock.drain_events();
    for i in 10..40 {
        lock.operation(&format!("passer-{i}"));
    }
    assert_eq!(
        lock.find_operation("faulted").unwrap_err().code(),
        "UNKNOWN_OPERATION"
    );
    assert_eq!(lock.find_operation("holder"), Ok(holder));
}

mod forgetting_model {
    use super::*;
    use proptest::prelude::*;

    #[derive(Clone, Debug)]
    enum Call {
        Acquire { op: usize, mask: u8, priority: i32 },
        Release { op: usize },
        Cancel { op: usize },
        Fault { op: usize },
        Clear { mask: u8 },
        Drain,
    }

    fn call() -> impl Strategy<Value = Call> {
        let op = 0..24usize;
        let mask = 1u8..32;
        prop_oneof![
            6 => (op.clone(), mask.clone(), 0..3i32)
                .prop_map(|(op, mask, priority)| Call::Acquire { op, mask, priority }),
            4 => op.clone().prop_map(|op| Call::Release { op }),
            1 => op.clone().prop_map(|op| Call::Cancel { op }),
            1 => op.prop_map(|op| Call::Fault { op }),
            2 => mask.prop_map(|mask| Call::Clear { mask }),
            2 => Just(Call::Drain),
        ]
    }

    fn lines(lock: &Interlock, mask: u8) -> ResourceSet {
        let names: Vec<&str> = ["YEL", "GRN", "BLU", "PUR", "RED"]
            .into_iter()
            .enumerate()
            .filter(|(i, _)| mask & (1 << i) != 0)
            .map(|(_, n)| n)
            .collect();
        set(lock, &names)
    }

    /// What a caller sees of a call, by name: never a handle.
    fn apply(lock: &mut Interlock, call: &Call, now: u64) -> String {
        let names = |lock: &Interlock, grants: Vec<Grant>| -> Vec<String> {
            grants
                .iter()
                .map(|g| lock.operation_name(g.operation).unwrap().to_owned())
                .collect()
        };
        match call {
            Call::Acquire { op, mask, priority } => {
                let id = lock.operation(&format!("op{op}"));
                let lines = lines(lock, *mask);
                format!(
                    "{:?}",
                    lock.acquire(id, *priority, &lines, ms(now))
                        .map_err(|e| e.code())
                )
            }
            Call::Release { op } => {
                let out = lock.release_named(&format!("op{op}"), ms(now));
                format!("{:?}", out.map(|g| names(lock, g)).map_err(|e| e.code()))
            }
            Call::Cancel { op } => {
                let out = lock.cancel_named(&format!("op{op}"), ms(now));
                format!("{:?}", out.map(|g| names(lock, g)).map_err(|e| e.code()))
            }
            // An idle operation and a forgotten one are both unknown to a fault.
            Call::Fault { op } => {
                let out = lock
                    .find_operation(&format!("op{op}"))
                    .and_then(|id| lock.fault(id, None, ms(now)));
                let out = out.map(|o| (o.lockouts.len(), o.dropped, names(lock, o.grants)));
                format!("{:?}", out.map_err(|e| e.code()))
            }
            Call::Clear { mask } => {
                let lines = lines(lock, *mask);
                let out = lock.clear(&lines, ms(now));
                format!("{:?}", out.map(|g| names(lock, g)).map_err(|e| e.code()))
            }
            Call::Drain => {
                let events = lock.drain_events();
                format!(
                    "{:?}",
                    events.iter().map(|e| lock.describe(e)).collect::<Vec<_>>()
                )
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// An interlock that forgets idle names after 2 behaves, by name,
        /// exactly as one that never forgets, and stays bounded.
        #[test]
        fn forgetting_idle_names_is_invisible_by_name(calls in prop::collection::vec(call(), 1..120)) {
            let mut forgetful = keeping_names(plant(Policy::NoOvertaking), 2);
            let mut keeping = plant(Policy::NoOvertaking);
            let mut peak_busy = 0;
            for (step, call) in calls.iter().enumerate() {
                let now = step as u64 * 10;
                prop_assert_eq!(apply(&mut forgetful, call, now), apply(&mut keeping, call, now), "step {}: {:?}", step, call);
                // Holds are listed by slot, and slots are reused: compare them as a set.
                let by_name = |mut snapshot: Snapshot| {
                    snapshot.holds.sort_by(|a, b| a.operation.cmp(&b.operation));
                    snapshot
                };
                prop_assert_eq!(by_name(forgetful.snapshot(ms(now))), by_name(keeping.snapshot(ms(now))));
                let c = forgetful.counts();
                // Names held by busy operations (a fault or an event names at most one).
                peak_busy = peak_busy.max(c.holding + c.queued + c.faulted + forgetful.events.len());
                prop_assert!(forgetful.known_operations() <= 2usize.max(2 * peak_busy) + 1);
            }
        }
    }
}
