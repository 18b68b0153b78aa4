//! Random sequences of interlock calls against a naive reference model: the
//! paper's Algorithms 1 and 2 taken literally (the whole queue sorted and
//! walked after every change), plus fault, clear, cancel, tick and restore;
//! and single mutations of a valid snapshot, which restore must refuse.

use std::collections::BTreeSet;
use sugarshack_core::time::ms;

use proptest::prelude::*;
use sugarshack_core::interlock::{
    Acquisition, EventKind, FaultCause, FaultOutcome, Interlock, InterlockConfig, InterlockError,
    Policy, RequestSnapshot, ResourceSnapshot, ResourceState, RestoreOptions, Snapshot,
};

const RESOURCES: [&str; 5] = ["YEL", "GRN", "BLU", "PUR", "RED"];
const OPS: usize = 6;
const QUEUE_BOUND: usize = 4;
const WARN_QUEUED_MS: u64 = 700;
const WARN_HELD_MS: u64 = 1500;

#[derive(Clone, Debug)]
enum Call {
    Acquire {
        op: usize,
        mask: u8,
    },
    Release {
        op: usize,
    },
    Fault {
        op: usize,
    },
    FaultResources {
        mask: u8,
    },
    Clear {
        mask: u8,
    },
    Cancel {
        op: usize,
    },
    Tick,
    /// Snapshot, through JSON, and restore under the same configuration.
    Restore {
        keep_queue: bool,
        keep_holds: bool,
    },
}

fn call() -> impl Strategy<Value = Call> {
    let op = 0..OPS;
    let mask = 1u8..32;
    prop_oneof![
        6 => (op.clone(), mask.clone()).prop_map(|(op, mask)| Call::Acquire { op, mask }),
        4 => op.clone().prop_map(|op| Call::Release { op }),
        1 => op.clone().prop_map(|op| Call::Fault { op }),
        1 => mask.clone().prop_map(|mask| Call::FaultResources { mask }),
        2 => mask.prop_map(|mask| Call::Clear { mask }),
        1 => op.prop_map(|op| Call::Cancel { op }),
        1 => Just(Call::Tick),
        2 => (any::<bool>(), any::<bool>())
            .prop_map(|(keep_queue, keep_holds)| Call::Restore { keep_queue, keep_holds }),
    ]
}

fn members(mask: u8) -> Vec<usize> {
    (0..RESOURCES.len())
        .filter(|r| mask & (1 << r) != 0)
        .collect()
}

fn names(set: &[usize]) -> Vec<&'static str> {
    set.iter().map(|&r| RESOURCES[r]).collect()
}

#[derive(Clone, Debug, PartialEq)]
enum Owner {
    Free,
    Held(usize),
    /// Faulted, remembering the operation it was faulted under, if any.
    Faulted(Option<usize>),
}

#[derive(Clone, Debug)]
struct Waiter {
    op: usize,
    priority: i32,
    set: Vec<usize>,
    seq: u64,
    since: u64,
    warned: bool,
}

#[derive(Clone, Debug)]
struct Held {
    set: Vec<usize>,
    since: u64,
    warned: bool,
}

/// What a call returned, in names, comparable between model and system.
#[derive(Clone, Debug, PartialEq)]
enum Outcome {
    Refused(&'static str),
    Acquired(bool),
    Grants(Vec<String>),
    Faulted {
        lockouts: Vec<&'static str>,
        dropped: bool,
        grants: Vec<String>,
    },
    Warnings(Vec<(String, &'static str)>),
    Restored,
}

#[derive(Clone, Debug)]
struct Model {
    policy: Policy,
    priorities: Vec<i32>,
    owners: Vec<Owner>,
    queue: Vec<Waiter>,
    holds: Vec<Option<Held>>,
    seq: u64,
    // Fates of requests that had to wait, so none is lost.
    queued_total: usize,
    granted_from_queue: usize,
    cancelled: usize,
    dropped: usize,
}

impl Model {
    fn new(policy: Policy, priorities: Vec<i32>) -> Self {
        Model {
            policy,
            priorities,
            owners: vec![Owner::Free; RESOURCES.len()],
            queue: Vec::new(),
            holds: vec![None; OPS],
            seq: 0,
            queued_total: 0,
            granted_from_queue: 0,
            cancelled: 0,
            dropped: 0,
        }
    }

    /// When the next elapsed-time warning is due: the earliest wait or hold not warned about yet crossing its limit.
    fn next_warning(&self) -> Option<u64> {
        let waits = self
            .queue
            .iter()
            .filter(|w| !w.warned)
            .map(|w| w.since + WARN_QUEUED_MS);
        let holds = self
            .holds
            .iter()
            .flatten()
            .filter(|h| !h.warned)
            .map(|h| h.since + WARN_HELD_MS);
        waits.chain(holds).min()
    }

    fn sorted_queue(&self) -> Vec<Waiter> {
        let mut queue = self.queue.clone();
        queue.sort_by(|a, b| b.priority.cmp(&a.priority).then(a.seq.cmp(&b.seq)));
        queue
    }

    fn all_free(&self, set: &[usize]) -> bool {
        set.iter().all(|&r| self.owners[r] == Owner::Free)
    }

    /// Algorithm 2's walk; under no-overtaking a waiter that is not granted
    /// reserves its resources against every waiter behind it.
    fn pass(&mut self, now: u64) -> Vec<String> {
        let mut reserved = BTreeSet::new();
        let mut granted = Vec::new();
        for waiter in self.sorted_queue() {
            let clear = self.all_free(&waiter.set)
                && (self.policy == Policy::Greedy
                    || waiter.set.iter().all(|r| !reserved.contains(r)));
            if clear {
                self.queue.retain(|w| w.op != waiter.op);
                for &r in &waiter.set {
                    self.owners[r] = Owner::Held(waiter.op);
                }
                self.holds[waiter.op] = Some(Held {
                    set: waiter.set.clone(),
                    since: now,
                    warned: false,
                });
                self.granted_from_queue += 1;
                granted.push(format!("op{}", waiter.op));
            } else {
                reserved.extend(waiter.set.iter().copied());
            }
        }
        granted
    }

    fn apply(&mut self, call: &Call, now: u64) -> Outcome {
        match *call {
            Call::Acquire { op, mask } => {
                let set = members(mask);
                if self.holds[op].is_some() {
                    return Outcome::Refused("ALREADY_HOLDING");
                }
                if self.queue.iter().any(|w| w.op == op) {
                    return Outcome::Refused("ALREADY_QUEUED");
                }
                let priority = self.priorities[op];
                let overtakes = self.policy == Policy::NoOvertaking
                    && self
                        .queue
                        .iter()
                        .any(|w| w.priority >= priority && w.set.iter().any(|r| set.contains(r)));
                if self.all_free(&set) && !overtakes {
                    for &r in &set {
                        self.owners[r] = Owner::Held(op);
                    }
                    self.holds[op] = Some(Held {
                        set,
                        since: now,
                        warned: false,
                    });
                    self.seq += 1;
                    return Outcome::Acquired(true);
                }
                if self.queue.len() >= QUEUE_BOUND {
                    return Outcome::Refused("QUEUE_FULL");
                }
                self.queue.push(Waiter {
                    op,
                    priority,
                    set,
                    seq: self.seq,
                    since: now,
                    warned: false,
                });
                self.seq += 1;
                self.queued_total += 1;
                Outcome::Acquired(false)
            }
            Call::Release { op } => {
                let Some(held) = self.holds[op].take() else {
                    return Outcome::Refused("NOT_HOLDING");
                };
                for &r in &held.set {
                    if self.owners[r] == Owner::Held(op) {
                        self.owners[r] = Owner::Free;
                    }
                }
                Outcome::Grants(self.pass(now))
            }
            Call::Cancel { op } => {
                if !self.queue.iter().any(|w| w.op == op) {
                    return Outcome::Refused("NOT_QUEUED");
                }
                self.queue.retain(|w| w.op != op);
                self.cancelled += 1;
                Outcome::Grants(self.pass(now))
            }
            Call::Fault { op } => {
                let named = self.owners.contains(&Owner::Faulted(Some(op)));
                if self.holds[op].is_none() && !self.queue.iter().any(|w| w.op == op) && !named {
                    return Outcome::Refused("UNKNOWN_OPERATION");
                }
                let mut dropped = false;
                let mut grants = vec![];
                if let Some(held) = self.holds[op].take() {
                    for &r in &held.set {
                        self.owners[r] = Owner::Faulted(Some(op));
                    }
                } else if self.queue.iter().any(|w| w.op == op) {
                    self.queue.retain(|w| w.op != op);
                    self.dropped += 1;
                    dropped = true;
                    grants = self.pass(now);
                }
                let lockouts: Vec<usize> = (0..RESOURCES.len())
                    .filter(|&r| self.owners[r] == Owner::Faulted(Some(op)))
                    .collect();
                Outcome::Faulted {
                    lockouts: names(&lockouts),
                    dropped,
                    grants,
                }
            }
            Call::FaultResources { mask } => {
                let mut latched: BTreeSet<usize> = members(mask).into_iter().collect();
                for r in members(mask) {
                    match self.owners[r] {
                        Owner::Free => self.owners[r] = Owner::Faulted(None),
                        Owner::Held(op) => {
                            let held = self.holds[op].take().unwrap();
                            for &h in &held.set {
                                self.owners[h] = Owner::Faulted(Some(op));
                                latched.insert(h);
                            }
                        }
                        Owner::Faulted(_) => {}
                    }
                }
                Outcome::Faulted {
                    lockouts: names(&latched.into_iter().collect::<Vec<_>>()),
                    dropped: false,
                    grants: vec![],
                }
            }
            Call::Clear { mask } => {
                let set = members(mask);
                if set
                    .iter()
                    .any(|&r| !matches!(self.owners[r], Owner::Faulted(_)))
                {
                    return Outcome::Refused("NOT_FAULTED");
                }
                for &r in &set {
                    self.owners[r] = Owner::Free;
                }
                Outcome::Grants(self.pass(now))
            }
            Call::Tick => {
                let mut warnings = Vec::new();
                for waiter in self.sorted_queue() {
                    if now - waiter.since >= WARN_QUEUED_MS && !waiter.warned {
                        self.queue
                            .iter_mut()
                            .find(|w| w.op == waiter.op)
                            .unwrap()
                            .warned = true;
                        warnings.push((format!("op{}", waiter.op), "warn-queued"));
                    }
                }
                for (op, held) in self.holds.iter_mut().enumerate() {
                    if let Some(held) = held {
                        if now - held.since >= WARN_HELD_MS && !held.warned {
                            held.warned = true;
                            warnings.push((format!("op{op}"), "warn-held"));
                        }
                    }
                }
                warnings.sort();
                Outcome::Warnings(warnings)
            }
            Call::Restore {
                keep_queue,
                keep_holds,
            } => {
                // Warnings already given are not saved: a kept wait or hold warns again.
                if keep_holds {
                    for held in self.holds.iter_mut().flatten() {
                        held.warned = false;
                    }
                } else {
                    // Held resources come back faulted, their operations idle.
                    for r in 0..RESOURCES.len() {
                        if let Owner::Held(op) = self.owners[r] {
                            self.owners[r] = Owner::Faulted(Some(op));
                        }
                    }
                    self.holds = vec![None; OPS];
                }
                if keep_queue {
                    for waiter in &mut self.queue {
                        waiter.warned = false;
                    }
                } else {
                    self.dropped += self.queue.len();
                    self.queue.clear();
                }
                Outcome::Restored
            }
        }
    }
}

fn config(policy: Policy) -> InterlockConfig {
    let mut config = InterlockConfig::with_resources(RESOURCES);
    config.policy = policy;
    config.queue_bound = QUEUE_BOUND;
    config.warn_queued_ms = Some(ms(WARN_QUEUED_MS));
    config.warn_held_ms = Some(ms(WARN_HELD_MS));
    config
}

fn op_name(lock: &Interlock, op: sugarshack_core::interlock::OpId) -> String {
    lock.operation_name(op).unwrap().to_owned()
}

fn refused(err: InterlockError) -> Outcome {
    Outcome::Refused(err.code().name())
}

fn apply(lock: &mut Interlock, priorities: &[i32], call: &Call, now: u64) -> Outcome {
    let op = |lock: &mut Interlock, i: usize| lock.operation(&format!("op{i}"));
    let set = |lock: &Interlock, mask: u8| lock.resource_set(&names(&members(mask))).unwrap();
    let grant_names = |lock: &Interlock, grants: &[sugarshack_core::interlock::Grant]| {
        grants
            .iter()
            .map(|g| op_name(lock, g.operation))
            .collect::<Vec<_>>()
    };
    let faulted = |lock: &Interlock, f: FaultOutcome| Outcome::Faulted {
        lockouts: f
            .lockouts
            .iter()
            .map(|l| RESOURCES[l.resource.index()])
            .collect(),
        dropped: f.dropped,
        grants: grant_names(lock, &f.grants),
    };
    match *call {
        Call::Acquire { op: i, mask } => {
            let id = op(lock, i);
            let set = set(lock, mask);
            match lock.acquire(id, priorities[i], &set, ms(now)) {
                Ok(a) => Outcome::Acquired(a == Acquisition::Granted),
                Err(e) => refused(e),
            }
        }
        Call::Release { op: i } => {
            let id = op(lock, i);
            match lock.release(id, ms(now)) {
                Ok(g) => Outcome::Grants(grant_names(lock, &g)),
                Err(e) => refused(e),
            }
        }
        Call::Cancel { op: i } => {
            let id = op(lock, i);
            match lock.cancel(id, ms(now)) {
                Ok(g) => Outcome::Grants(grant_names(lock, &g)),
                Err(e) => refused(e),
            }
        }
        Call::Fault { op: i } => {
            let id = op(lock, i);
            match lock.fault(id, Some("test"), ms(now)) {
                Ok(f) => faulted(lock, f),
                Err(e) => refused(e),
            }
        }
        Call::FaultResources { mask } => {
            let set = set(lock, mask);
            let f = lock.fault_resources(&set, None, ms(now)).unwrap();
            faulted(lock, f)
        }
        Call::Clear { mask } => {
            let set = set(lock, mask);
            match lock.clear(&set, ms(now)) {
                Ok(g) => Outcome::Grants(grant_names(lock, &g)),
                Err(e) => refused(e),
            }
        }
        Call::Tick => Outcome::Warnings({
            let mut warnings: Vec<_> = lock
                .tick(ms(now))
                .iter()
                .map(|w| {
                    let kind = match w.kind() {
                        sugarshack_core::interlock::EventKind::WarnQueued => "warn-queued",
                        _ => "warn-held",
                    };
                    (op_name(lock, w.operation().unwrap()), kind)
                })
                .collect();
            warnings.sort();
            warnings
        }),
        Call::Restore {
            keep_queue,
            keep_holds,
        } => {
            let options = RestoreOptions {
                keep_queue,
                keep_holds,
            };
            let before = lock.snapshot(ms(now));
            let json = serde_json::to_value(&before).unwrap();
            let parsed: Snapshot = serde_json::from_value(json).unwrap();
            let (mut restored, grants) =
                Interlock::restore(lock.config().clone(), &parsed, options, ms(now)).unwrap();
            assert!(
                grants.is_empty(),
                "same configuration: nothing becomes grantable on restore"
            );
            assert_round_trip(&before, &restored.snapshot(ms(now)), options);
            // Same configuration: no line added or dropped, only the holds and
            // waiters the options let go are reported.
            let mut interrupted = 0;
            let mut dropped = 0;
            for event in restored.drain_events() {
                match event.kind() {
                    EventKind::Interrupted if event.operation().is_some() => interrupted += 1,
                    EventKind::Dropped => dropped += 1,
                    other => panic!("unexpected {other:?} on restore under the same configuration"),
                }
            }
            assert_eq!(interrupted, if keep_holds { 0 } else { before.holds.len() });
            assert_eq!(dropped, if keep_queue { 0 } else { before.queue.len() });
            *lock = restored;
            Outcome::Restored
        }
    }
}

/// Restore keeps faults, keeps holds or turns each held resource into an
/// interrupted fault, and keeps or drops the queue; nothing else changes.
fn assert_round_trip(before: &Snapshot, after: &Snapshot, options: RestoreOptions) {
    assert_eq!(after.configured, before.configured);
    if options.keep_queue {
        assert_eq!(
            after.queue, before.queue,
            "waiting requests keep their order"
        );
    } else {
        assert!(after.queue.is_empty());
    }
    if options.keep_holds {
        let by_operation = |holds: &[RequestSnapshot]| {
            let mut holds = holds.to_vec();
            holds.sort_by(|a, b| a.operation.cmp(&b.operation));
            holds
        };
        assert_eq!(by_operation(&after.holds), by_operation(&before.holds));
        assert_eq!(after.resources, before.resources);
        return;
    }
    assert!(after.holds.is_empty());
    assert_eq!(after.resources.len(), before.resources.len());
    for (b, a) in before.resources.iter().zip(&after.resources) {
        assert_eq!(a.name, b.name);
        match (&b.state, &a.state) {
            (ResourceState::Held { operation }, ResourceState::Faulted(f)) => {
                assert_eq!(f.cause, FaultCause::Interrupted);
                assert_eq!(f.operation.as_ref(), Some(operation));
            }
            (b, a) => assert_eq!(a, b),
        }
    }
}

/// The system's state in model terms.
fn observed_owners(lock: &Interlock) -> Vec<Owner> {
    lock.snapshot(ms(0))
        .resources
        .iter()
        .map(|r| match &r.state {
            ResourceState::Free => Owner::Free,
            ResourceState::Held { operation } => Owner::Held(operation[2..].parse().unwrap()),
            ResourceState::Faulted(f) => {
                Owner::Faulted(f.operation.as_ref().map(|o| o[2..].parse().unwrap()))
            }
        })
        .collect()
}

fn check_invariants(
    lock: &Interlock,
    model: &Model,
    pre_faulted: &[bool],
    call: &Call,
    outcome: &Outcome,
) {
    let snapshot = lock.snapshot(ms(0));
    // No resource has two owners: holds are disjoint and match ownership.
    let mut taken = BTreeSet::new();
    for hold in &snapshot.holds {
        for r in &hold.resources {
            assert!(taken.insert(r.clone()), "{r} held twice");
            let index = RESOURCES.iter().position(|n| n == r).unwrap();
            assert_eq!(
                snapshot.resources[index].state,
                ResourceState::Held {
                    operation: hold.operation.clone()
                },
                "{r} listed in {}'s hold",
                hold.operation
            );
        }
    }
    // A faulted resource is never granted before it is cleared.
    let granted: Vec<String> = match outcome {
        Outcome::Grants(g) => g.clone(),
        Outcome::Faulted { grants, .. } => grants.clone(),
        Outcome::Acquired(true) => match call {
            Call::Acquire { op, .. } => vec![format!("op{op}")],
            _ => unreachable!(),
        },
        _ => vec![],
    };
    let cleared = match call {
        Call::Clear { mask } if !matches!(outcome, Outcome::Refused(_)) => members(*mask),
        _ => vec![],
    };
    for name in &granted {
        let hold = snapshot
            .holds
            .iter()
            .find(|h| &h.operation == name)
            .expect("granted op holds");
        for r in &hold.resources {
            let index = RESOURCES.iter().position(|n| n == r).unwrap();
            assert!(
                !pre_faulted[index] || cleared.contains(&index),
                "{name} was granted faulted {r}"
            );
        }
    }
    // Grants of one call come in queue order: priority never increases.
    let priorities: Vec<i32> = granted
        .iter()
        .map(|n| model.priorities[n[2..].parse::<usize>().unwrap()])
        .collect();
    assert!(
        priorities.windows(2).all(|w| w[0] >= w[1]),
        "grants out of priority order: {granted:?} {priorities:?}"
    );
    // Nothing is left waiting that could go now.
    let owners = observed_owners(lock);
    let queued = lock.queued_operations();
    for (position, &op) in queued.iter().enumerate() {
        let name = op_name(lock, op);
        let request = snapshot.queue.iter().find(|q| q.operation == name).unwrap();
        let set: Vec<usize> = request
            .resources
            .iter()
            .map(|r| RESOURCES.iter().position(|n| n == r).unwrap())
            .collect();
        let free = set.iter().all(|&r| owners[r] == Owner::Free);
        let reserved_ahead = snapshot.queue[..position].iter().any(|ahead| {
            ahead
                .resources
                .iter()
                .any(|r| request.resources.contains(r))
        });
        match model.policy {
            Policy::Greedy => assert!(!free, "{name} waits with all its resources free"),
            Policy::NoOvertaking => assert!(
                !free || reserved_ahead,
                "{name} waits though free and nobody ahead needs them"
            ),
        }
    }
    // No request is lost: each waiting request was granted, cancelled, dropped, or still waits.
    assert_eq!(
        model.queued_total,
        model.granted_from_queue + model.cancelled + model.dropped + model.queue.len(),
    );
}

fn run(policy: Policy, priorities: Vec<i32>, calls: Vec<(Call, u64)>) {
    let mut model = Model::new(policy, priorities.clone());
    let mut lock = Interlock::new(config(policy)).unwrap();
    let mut now = 0;
    for (call, dt) in &calls {
        now += dt;
        let pre_faulted: Vec<bool> = observed_owners(&lock)
            .iter()
            .map(|o| matches!(o, Owner::Faulted(_)))
            .collect();
        let expected = model.apply(call, now);
        let actual = apply(&mut lock, &priorities, call, now);
        assert_eq!(actual, expected, "call {call:?} at {now}");
        assert_eq!(
            observed_owners(&lock),
            model.owners,
            "owners after {call:?}"
        );
        let queued: Vec<String> = lock
            .queued_operations()
            .iter()
            .map(|&op| op_name(&lock, op))
            .collect();
        let expected_queue: Vec<String> = model
            .sorted_queue()
            .iter()
            .map(|w| format!("op{}", w.op))
            .collect();
        assert_eq!(queued, expected_queue, "queue after {call:?}");
        for i in 0..OPS {
            if let Ok(op) = lock.find_operation(&format!("op{i}")) {
                assert_eq!(
                    lock.is_holding(op),
                    model.holds[i].is_some(),
                    "op{i} holding after {call:?}"
                );
            }
        }
        let counts = lock.counts();
        assert_eq!(counts.queued, model.queue.len());
        assert_eq!(counts.holding, model.holds.iter().flatten().count());
        assert_eq!(
            counts.faulted,
            model
                .owners
                .iter()
                .filter(|o| matches!(o, Owner::Faulted(_)))
                .count()
        );
        check_invariants(&lock, &model, &pre_faulted, call, &actual);
        assert_eq!(
            lock.next_warning().map(|at| at.as_u64()),
            model.next_warning(),
            "next warning after {call:?}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn greedy_matches_the_reference_model(
        priorities in proptest::collection::vec(0i32..3, OPS),
        calls in proptest::collection::vec((call(), 0u64..400), 1..80),
    ) {
        run(Policy::Greedy, priorities, calls);
    }

    #[test]
    fn no_overtaking_matches_the_reference_model(
        priorities in proptest::collection::vec(0i32..3, OPS),
        calls in proptest::collection::vec((call(), 0u64..400), 1..80),
    ) {
        run(Policy::NoOvertaking, priorities, calls);
    }
}

/// One change to a valid snapshot that makes it contradict itself.
#[derive(Clone, Debug)]
enum Mutation {
    DropLine(usize),
    DuplicateLine(usize),
    /// Swap one line of a hold for a line the hold does not have.
    MoveHoldLine {
        hold: usize,
        from: usize,
        to: usize,
    },
    AddUnknownLine,
    /// Give an operation that holds a second hold.
    SecondHold {
        hold: usize,
        line: usize,
    },
    /// Forget a hold whose lines still say they are held.
    DropHold(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let any_index = 0usize..16;
    prop_oneof![
        any_index.clone().prop_map(Mutation::DropLine),
        any_index.clone().prop_map(Mutation::DuplicateLine),
        (any_index.clone(), any_index.clone(), any_index.clone())
            .prop_map(|(hold, from, to)| Mutation::MoveHoldLine { hold, from, to }),
        Just(Mutation::AddUnknownLine),
        (any_index.clone(), any_index.clone())
            .prop_map(|(hold, line)| Mutation::SecondHold { hold, line }),
        any_index.prop_map(Mutation::DropHold),
    ]
}

/// Applies the mutation; one that needs a hold, on a snapshot with none,
/// duplicates a line instead.
fn mutate(snapshot: &mut Snapshot, mutation: &Mutation) {
    let lines = snapshot.resources.len();
    match *mutation {
        Mutation::DropLine(i) => {
            snapshot.resources.remove(i % lines);
        }
        Mutation::DuplicateLine(i) => {
            let copy = snapshot.resources[i % lines].clone();
            snapshot.resources.insert(i % (lines + 1), copy);
        }
        Mutation::AddUnknownLine => snapshot.resources.push(ResourceSnapshot {
            name: "ORANGE".into(),
            state: ResourceState::Free,
        }),
        Mutation::MoveHoldLine { hold, from, to } if !snapshot.holds.is_empty() => {
            let count = snapshot.holds.len();
            let hold = &mut snapshot.holds[hold % count];
            let others: Vec<&str> = RESOURCES
                .iter()
                .copied()
                .filter(|r| !hold.resources.iter().any(|h| h == r))
                .collect();
            if others.is_empty() {
                // The hold has every line: none to move to.
                hold.resources.remove(from % hold.resources.len());
            } else {
                let from = from % hold.resources.len();
                hold.resources[from] = others[to % others.len()].to_owned();
            }
        }
        Mutation::SecondHold { hold, line } if !snapshot.holds.is_empty() => {
            let count = snapshot.holds.len();
            let operation = snapshot.holds[hold % count].operation.clone();
            snapshot.holds.push(RequestSnapshot {
                operation,
                priority: 0,
                resources: vec![RESOURCES[line % RESOURCES.len()].to_owned()],
                since_ms: ms(0),
                waited_ms: ms(0),
            });
        }
        Mutation::DropHold(hold) if !snapshot.holds.is_empty() => {
            let count = snapshot.holds.len();
            snapshot.holds.remove(hold % count);
        }
        Mutation::MoveHoldLine { from: i, .. }
        | Mutation::SecondHold { line: i, .. }
        | Mutation::DropHold(i) => mutate(snapshot, &Mutation::DuplicateLine(i)),
    }
}

fn play(policy: Policy, priorities: &[i32], calls: &[(Call, u64)]) -> (Interlock, u64) {
    let mut lock = Interlock::new(config(policy)).unwrap();
    let mut now = 0;
    for (call, dt) in calls {
        now += dt;
        apply(&mut lock, priorities, call, now);
    }
    (lock, now)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn a_mutated_snapshot_is_refused_never_restored_free(
        no_overtaking in any::<bool>(),
        priorities in proptest::collection::vec(0i32..3, OPS),
        calls in proptest::collection::vec((call(), 0u64..400), 0..60),
        clear_faults in any::<bool>(),
        tail in proptest::collection::vec((0..OPS, 1u8..32), 1..4),
        mutation in mutation(),
    ) {
        let policy = if no_overtaking { Policy::NoOvertaking } else { Policy::Greedy };
        let (mut lock, now) = play(policy, &priorities, &calls);
        // End on acquisitions, so most snapshots have holds to mutate.
        let faulted = lock.faulted_resources();
        if clear_faults && !faulted.is_empty() {
            lock.clear(&faulted, ms(now)).unwrap();
        }
        for &(op, mask) in &tail {
            apply(&mut lock, &priorities, &Call::Acquire { op, mask }, now);
        }
        let mut snapshot = lock.snapshot(ms(now));
        mutate(&mut snapshot, &mutation);
        // What a store would hand back.
        let json = serde_json::to_value(&snapshot).unwrap();
        let parsed: Snapshot = serde_json::from_value(json).unwrap();
        for (keep_queue, keep_holds) in [(false, false), (true, false), (false, true), (true, true)] {
            let options = RestoreOptions { keep_queue, keep_holds };
            match Interlock::restore(lock.config().clone(), &parsed, options, ms(now + 1)) {
                Ok((restored, _)) => panic!(
                    "{mutation:?} restored as {:?}",
                    restored.snapshot(ms(now + 1)).resources
                ),
                Err(err) => prop_assert_eq!(err.code(), "INVALID_SNAPSHOT"),
            }
        }
    }
}
