//! Every transition the ISA-88 tables declare, one by one, on a run of a fill
//! operation: each allowed command leads where the table says, each refusal
//! gives its code and words and changes nothing, and each event the tables
//! list moves a run that way. Then what each state does to the plant, effect
//! by effect: the hold command, the restore and the time a step has left, the
//! stop's return to idle, the abort's lockout, a held run across a restart.

use serde_json::json;
use sugarshack_core::clearance::Attribution;
use sugarshack_core::code::Code;
use sugarshack_core::operation::{OperationRun, PlanStep, RunEffect, RunOwner, StepKind};
use sugarshack_core::plant::{GroupCommand, Plant, PlantModel};
use sugarshack_core::procedure::{Command, Event, State, Verdict, OPERATION, OPERATION_EVENTS};
use sugarshack_core::time::ms;

fn group(written: serde_json::Value) -> GroupCommand {
    serde_json::from_value(written).expect("a group command")
}

/// A fill: open the feed valve and start the pump, wait for the level, stop
/// the pump. A hold stops the pump and closes the feed.
fn plant(stop: &str) -> Plant {
    let doc = json!({
        "actuatorTypes": {
            "valve": { "signal": "analog", "noMotionMs": 1000, "completionMs": 5000, "staleMs": 3000 },
            "pump": { "signal": "binary", "noMotionMs": 1000, "completionMs": 2000, "staleMs": 3000 }
        },
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }, { "id": "st", "kind": "sensor-station" }],
        "actuators": [
            { "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "idle": 0, "lockout": 0, "resource": "YEL" },
            { "id": "V2", "type": "valve", "device": "ctrl-1", "io": 2, "idle": 0, "lockout": 0, "resource": "YEL" },
            { "id": "P1", "type": "pump", "device": "ctrl-1", "io": 1, "idle": false, "lockout": false, "resource": "YEL" }
        ],
        "sensors": [{ "id": "LT-3", "device": "st", "name": "volume" }],
        "resources": [{ "id": "YEL" }],
        "operations": [{
            "id": "fill", "priority": 10, "resources": ["YEL"],
            "hold": { "command": { "pumps": { "P1": false }, "valves": { "V1": 0 } }, "timeoutMs": 4000 },
            "stop": stop,
            "steps": [
                { "command": { "valves": { "V1": 100, "V2": 100 } }, "timeoutMs": 20000 },
                { "command": { "pumps": { "P1": true } }, "timeoutMs": 5000 },
                { "wait": "`LT-3` >= 1000", "sensors": ["LT-3"], "timeoutMs": 60000, "restart": "rerun" },
                { "command": { "pumps": { "P1": false } }, "timeoutMs": 5000 }
            ]
        }]
    });
    Plant::new(serde_json::from_value::<PlantModel>(doc).unwrap()).unwrap()
}

fn who() -> Attribution {
    Attribution::new(Some("ana"), Some("gasket check"), false)
}

fn run() -> OperationRun {
    OperationRun::of(&plant("finish-step"), "fill").unwrap()
}

fn cmd(r: &mut OperationRun, c: Command, at: u64) -> Vec<RunEffect> {
    r.command(c, &who(), ms(at)).unwrap()
}

/// The attempt the run waits for (none: one it never asked for).
fn cur(r: &OperationRun) -> u32 {
    r.attempt().unwrap_or(u32::MAX)
}

/// A run in `state`, reached one way per entry of `ways`: each a name and the run.
fn ways(state: State) -> Vec<(&'static str, OperationRun)> {
    let mut all: Vec<(&'static str, OperationRun)> = Vec::new();
    let mut r = run();
    let mut add = |name, r: &OperationRun| all.push((name, r.clone()));
    match state {
        State::Idle => add("new", &r),
        _ => {
            cmd(&mut r, Command::Start, 0);
            let queued = r.clone();
            let granted = |at_step: usize| {
                let mut r = queued.clone();
                r.granted(ms(100));
                for i in 0..at_step {
                    r.step_done(i as u32, ms(200 + i as u64));
                }
                r
            };
            match state {
                State::Queued => add("started", &queued),
                State::Running => {
                    add("granted, at the wait", &granted(2));
                    add("granted, at the return to idle", &granted(4));
                }
                State::Holding => {
                    let mut r = granted(2);
                    cmd(&mut r, Command::Hold, 1000);
                    add("held in the wait", &r);
                }
                State::Held => {
                    let mut r = granted(2);
                    cmd(&mut r, Command::Hold, 1000);
                    r.hold_done(cur(&r), ms(1100));
                    add("held in the wait", &r);
                }
                State::Restarting => {
                    let mut r = granted(2);
                    cmd(&mut r, Command::Hold, 1000);
                    r.hold_done(cur(&r), ms(1100));
                    cmd(&mut r, Command::Restart, 2000);
                    add("restarting in the wait", &r);
                }
                State::Stopping => {
                    let mut q = queued.clone();
                    cmd(&mut q, Command::Stop, 10);
                    add("stopped while queued", &q);
                    let mut c = q.clone();
                    c.granted(ms(20));
                    add("stopped while queued, a grant crossed", &c);
                    let mut r = granted(2);
                    cmd(&mut r, Command::Stop, 1000);
                    add("stopped in the wait", &r);
                    let mut r = granted(2);
                    cmd(&mut r, Command::Stop, 1000);
                    r.step_done(cur(&r), ms(1200));
                    r.step_done(cur(&r), ms(1300));
                    add("stopped, back at idle, releasing", &r);
                }
                State::Aborting => {
                    let mut q = queued.clone();
                    cmd(&mut q, Command::Abort, 10);
                    add("aborted while queued", &q);
                    let mut c = q.clone();
                    c.granted(ms(20));
                    add("aborted while queued, a grant crossed", &c);
                    let mut r = granted(2);
                    cmd(&mut r, Command::Abort, 1000);
                    add("aborted in the wait", &r);
                    let mut r = granted(2);
                    cmd(&mut r, Command::Stop, 1000);
                    r.step_done(cur(&r), ms(1200));
                    r.step_done(cur(&r), ms(1300));
                    cmd(&mut r, Command::Abort, 1400);
                    add("aborted while a stop released", &r);
                }
                State::Aborted => {
                    let mut r = granted(2);
                    cmd(&mut r, Command::Abort, 1000);
                    r.fault_applied(vec!["YEL".into()], ms(1001));
                    add("aborted in the wait", &r);
                }
                State::Stopped => {
                    let mut q = queued.clone();
                    cmd(&mut q, Command::Stop, 10);
                    q.withdrawn(ms(11));
                    add("stopped while queued", &q);
                }
                State::Completing => {
                    let mut r = granted(4);
                    r.step_done(4, ms(500));
                    add("every step done", &r);
                }
                State::Complete => {
                    let mut r = granted(4);
                    r.step_done(4, ms(500));
                    r.released(ms(600));
                    add("released", &r);
                }
                State::Faulting => {
                    let mut r = granted(2);
                    r.step_failed(2, "CONDITION_TIMEOUT", "late", ms(900));
                    add("the wait failed", &r);
                }
                State::Faulted => {
                    let mut r = granted(2);
                    r.step_failed(2, "CONDITION_TIMEOUT", "late", ms(900));
                    r.fault_applied(vec!["YEL".into()], ms(901));
                    add("the wait failed", &r);
                }
                State::Withdrawing => {
                    let mut q = queued.clone();
                    q.interrupt("its interlock left the flows", ms(10));
                    add("interrupted while queued", &q);
                    let mut c = q.clone();
                    c.granted(ms(20));
                    add("interrupted while queued, a grant crossed", &c);
                }
                State::Withdrawn => {
                    let mut q = queued.clone();
                    q.interrupt("its interlock left the flows", ms(10));
                    q.withdrawn(ms(11));
                    add("interrupted while queued", &q);
                }
                State::Refused => {
                    let mut q = queued.clone();
                    q.refused("QUEUE_FULL", "the queue is full");
                    add("refused", &q);
                }
                State::Idle => unreachable!(),
            }
        }
    }
    for (name, r) in &all {
        assert_eq!(r.state(), state, "{name}");
    }
    all
}

#[test]
fn every_command_the_table_allows_leads_where_it_says() {
    for &(from, command, to) in OPERATION.allowed {
        for (way, mut r) in ways(from) {
            if command == Command::Start && from != State::Idle {
                // A run is one start; a new run starts the operation again (see AbortedOperations).
                assert_eq!(
                    r.command(command, &who(), ms(5000)).unwrap_err().code(),
                    Code::AlreadyStarted
                );
                continue;
            }
            r.command(command, &who(), ms(5000))
                .unwrap_or_else(|e| panic!("{command} in {from} ({way}): {e}"));
            // A command that settles at once (nothing to put back) goes on by events.
            let settled = matches!((from, command), (State::Held, Command::Restart));
            assert!(
                r.state() == to || settled && r.state() == State::Running,
                "{command} in {from} ({way}) led to {}, not {to}",
                r.state()
            );
        }
    }
}

#[test]
fn every_command_the_table_refuses_is_refused_in_its_words_and_changes_nothing() {
    for state in State::ALL {
        for command in Command::ALL {
            let Verdict::Refused(code, why) = OPERATION.verdict(state, command) else {
                continue;
            };
            for (way, mut r) in ways(state) {
                let err = r.command(command, &who(), ms(5000)).unwrap_err();
                assert_eq!(err.code(), code, "{command} in {state} ({way})");
                assert!(err.to_string().ends_with(why), "{err}");
                assert_eq!(r.state(), state, "{command} in {state} ({way}) moved it");
            }
        }
    }
}

/// The inputs that report `event` to a run.
fn inputs_for(event: Event) -> Vec<fn(&mut OperationRun)> {
    match event {
        Event::Granted => vec![|r| drop(r.granted(ms(7000)))],
        Event::RequestRefused => vec![|r| drop(r.refused("QUEUE_FULL", "full"))],
        Event::Withdrawn => vec![|r| drop(r.withdrawn(ms(7000)))],
        Event::StepDone | Event::LastStepDone => {
            vec![|r| drop(r.step_done(cur(r), ms(7000)))]
        }
        Event::Failed => vec![
            |r| drop(r.step_failed(cur(r), "E", "x", ms(7000))),
            |r| drop(r.hold_failed(cur(r), "E", "x", ms(7000))),
            |r| drop(r.restart_failed(cur(r), "E", "x", ms(7000))),
        ],
        Event::HoldDone => vec![|r| drop(r.hold_done(cur(r), ms(7000)))],
        Event::RestartDone => vec![|r| drop(r.restart_done(cur(r), ms(7000)))],
        Event::Released => vec![|r| drop(r.released(ms(7000)))],
        Event::ReleaseFailed => vec![|r| drop(r.release_failed("NOT_HOLDING", "gone", ms(7000)))],
        Event::FaultApplied => vec![|r| drop(r.fault_applied(vec!["YEL".into()], ms(7000)))],
        Event::Interrupted => vec![|r| drop(r.interrupt("gone", ms(7000)))],
    }
}

#[test]
fn every_event_the_table_lists_moves_a_run_that_way() {
    for &(from, event, to) in OPERATION_EVENTS {
        let mut reached = Vec::new();
        for (way, r) in ways(from) {
            for input in inputs_for(event) {
                let mut r = r.clone();
                input(&mut r);
                reached.push((way, r.state()));
            }
        }
        assert!(
            reached.iter().any(|(_, state)| *state == to),
            "no run in {from} moved to {to} on {event:?}: {reached:?}"
        );
    }
}

fn plan_step(r: &OperationRun, i: usize) -> &PlanStep {
    &r.plan().steps[i]
}

#[test]
fn a_hold_sends_the_hold_command_and_nothing_else_until_restarted() {
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(100));
    r.step_done(0, ms(1000));
    r.step_done(1, ms(2000));
    // In the wait since 2 s; held at 12 s: 10 s of its 60 used.
    let held = cmd(&mut r, Command::Hold, 12_000);
    assert_eq!(
        serde_json::to_value(&held).unwrap(),
        json!([
            { "kind": "cancelStep", "index": 2, "attempt": 2 },
            { "kind": "entered", "state": "holding", "step": 2 },
            { "kind": "hold", "attempt": 3, "command": { "pumps": { "P1": false }, "valves": { "V1": 0 } }, "timeoutMs": 4000, "within": ["YEL"] }
        ])
    );
    assert_eq!(
        serde_json::to_value(r.hold_done(3, ms(13_000))).unwrap(),
        json!([{ "kind": "entered", "state": "held", "step": 2 }])
    );
    // Held: late reports of the cancelled step, a repeated hold report: nothing.
    assert!(r.step_done(2, ms(14_000)).is_empty());
    assert!(r
        .step_failed(2, "CONDITION_TIMEOUT", "late", ms(80_000))
        .is_empty());
    assert!(r.hold_done(3, ms(14_000)).is_empty());
    assert!(r.granted(ms(14_000)).is_empty());
    assert_eq!(
        r.commands(),
        [Command::Restart, Command::Stop, Command::Abort]
    );
    let refused = r.command(Command::Hold, &who(), ms(15_000)).unwrap_err();
    assert_eq!(
        refused.to_string(),
        "hold refused: operation 'fill' is held; it is held already"
    );

    // Restart at 100 s: V1 and P1 back where the run had them, then the wait again (rerun: its whole 60 s).
    let restarted = cmd(&mut r, Command::Restart, 100_000);
    assert_eq!(
        serde_json::to_value(&restarted).unwrap(),
        json!([
            { "kind": "entered", "state": "restarting", "step": 2 },
            { "kind": "restore", "attempt": 4, "command": { "pumps": { "P1": true }, "valves": { "V1": 100 } }, "timeoutMs": 4000, "within": ["YEL"] }
        ])
    );
    match r.restart_done(4, ms(101_000)).as_slice() {
        [RunEffect::Entered {
            state: State::Running,
            step: Some(2),
        }, RunEffect::StartStep {
            index: 2,
            timeout_ms,
            ..
        }] => {
            assert_eq!(*timeout_ms, ms(60_000), "rerun: the whole timeout");
        }
        other => panic!("{other:?}"),
    }
    r.step_done(5, ms(111_000));
    r.step_done(6, ms(112_000));
    r.step_done(7, ms(113_000));
    match r.released(ms(114_000)).as_slice() {
        [RunEffect::Finished {
            run_ms,
            held_ms,
            steps,
            ..
        }] => {
            assert_eq!(
                *held_ms,
                ms(89_000),
                "from the hold at 12 s to the restart done at 101 s"
            );
            assert_eq!(*run_ms, ms(113_900));
            assert_eq!(steps[2].kind, StepKind::Wait);
            assert_eq!(
                steps[2].ms,
                ms(10_000),
                "the rerun wait, held time not counted"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_late_answer_of_a_step_attempt_cancelled_by_a_hold_is_ignored_after_the_restart() {
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(0));
    // Step 0 (V1, V2 open) is attempt 0; the hold cancels it.
    let held = cmd(&mut r, Command::Hold, 1_000);
    assert!(matches!(
        held.as_slice(),
        [
            RunEffect::CancelStep {
                index: 0,
                attempt: 0
            },
            _,
            RunEffect::Hold { attempt: 1, .. }
        ]
    ));
    r.hold_done(1, ms(1_100));
    cmd(&mut r, Command::Restart, 2_000);
    // The same step again, a new attempt (after the hold's 1 and the restore's 2).
    match r.restart_done(2, ms(2_100)).as_slice() {
        [_, RunEffect::StartStep {
            index: 0,
            attempt: 3,
            ..
        }] => {}
        other => panic!("{other:?}"),
    }
    // The cancelled attempt's command completes (or fails) late: same step, earlier attempt, ignored.
    assert!(r.step_done(0, ms(2_200)).is_empty());
    assert!(r
        .step_failed(0, "COMMAND_TIMEOUT", "late", ms(2_200))
        .is_empty());
    // Late answers of the hold and the restore too.
    assert!(r.hold_done(1, ms(2_200)).is_empty());
    assert!(r
        .restart_failed(2, "COMMAND_FAILED", "late", ms(2_200))
        .is_empty());
    assert_eq!(
        (r.state(), r.step(), r.attempt()),
        (State::Running, Some(0), Some(3))
    );
    // The current attempt's answer moves it on.
    assert!(matches!(
        r.step_done(3, ms(3_000)).as_slice(),
        [RunEffect::StartStep {
            index: 1,
            attempt: 4,
            ..
        }]
    ));
}

#[test]
fn a_run_saved_before_attempts_were_numbered_comes_back_and_numbers_on() {
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(0));
    cmd(&mut r, Command::Hold, 1_000);
    r.hold_done(cur(&r), ms(1_100));
    let mut saved = serde_json::to_value(r.snapshot(None).unwrap()).unwrap();
    assert_eq!(saved["attempts"], 2);
    saved.as_object_mut().unwrap().remove("attempts");
    let saved = serde_json::from_value(saved).expect("a save without attempts");
    let plan = plant("finish-step").operation_plan("fill").unwrap();
    let (mut back, _) = OperationRun::restore(plan, &saved).unwrap();
    assert_eq!(back.state(), State::Held);
    match cmd(&mut back, Command::Restart, 2_000).as_slice() {
        [_, RunEffect::Restore { attempt: 0, .. }] => {}
        other => panic!("{other:?}"),
    }
    assert_eq!(back.restart_done(0, ms(2_100)).len(), 2);
}

#[test]
fn a_reissued_step_goes_on_with_the_time_it_had_left() {
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(0));
    // The first command step (V1, V2 open) 15 s into its 20 s.
    cmd(&mut r, Command::Hold, 15_000);
    r.hold_done(cur(&r), ms(16_000));
    // Nothing commanded before step 1: the hold's P1 goes back to idle; V1 is
    // the step's own, which it opens again.
    let restarted = cmd(&mut r, Command::Restart, 50_000);
    assert_eq!(
        serde_json::to_value(&restarted[1]).unwrap()["command"],
        json!({ "pumps": { "P1": false } })
    );
    match r.restart_done(cur(&r), ms(51_000)).as_slice() {
        [_, RunEffect::StartStep {
            index: 0,
            timeout_ms,
            step,
            ..
        }] => {
            assert_eq!(*timeout_ms, ms(5_000));
            assert_eq!(step, plan_step(&r, 0));
        }
        other => panic!("{other:?}"),
    }
    // Held again while restarting, then once more: the clock of the step stood still throughout.
    cmd(&mut r, Command::Hold, 52_000);
    r.hold_done(cur(&r), ms(52_500));
    cmd(&mut r, Command::Restart, 53_000);
    match r.restart_done(cur(&r), ms(53_500)).as_slice() {
        [_, RunEffect::StartStep { timeout_ms, .. }] => assert_eq!(*timeout_ms, ms(4_000)),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_restart_leaves_to_the_step_the_actuators_it_commands_itself() {
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(0));
    for i in 0..3 {
        r.step_done(i, ms(1000 + i as u64));
    }
    // Held in the last step, "P1 off": the restore opens V1 again but does
    // not start P1 only for the step to stop it.
    cmd(&mut r, Command::Hold, 5_000);
    r.hold_done(cur(&r), ms(5_500));
    let restarted = cmd(&mut r, Command::Restart, 9_000);
    assert_eq!(
        serde_json::to_value(&restarted).unwrap(),
        json!([
            { "kind": "entered", "state": "restarting", "step": 3 },
            { "kind": "restore", "attempt": 5, "command": { "valves": { "V1": 100 } }, "timeoutMs": 4000, "within": ["YEL"] }
        ])
    );
    match r.restart_done(5, ms(9_500)).as_slice() {
        [_, RunEffect::StartStep { index: 3, step, .. }] => assert_eq!(step, plan_step(&r, 3)),
        other => panic!("{other:?}"),
    }
    // Held in the return to idle, which commands every actuator the hold
    // set: nothing to restore, the step goes on at once.
    r.step_done(cur(&r), ms(10_000));
    cmd(&mut r, Command::Hold, 11_000);
    r.hold_done(cur(&r), ms(11_500));
    match cmd(&mut r, Command::Restart, 12_000).as_slice() {
        [RunEffect::Entered {
            state: State::Restarting,
            ..
        }, RunEffect::Entered {
            state: State::Running,
            ..
        }, RunEffect::StartStep { index: 4, .. }] => {}
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_stop_finishes_the_step_then_returns_to_idle_and_releases() {
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(0));
    r.step_done(0, ms(1000));
    assert_eq!(
        serde_json::to_value(cmd(&mut r, Command::Stop, 1500)).unwrap(),
        json!([{ "kind": "entered", "state": "stopping", "step": 1 }])
    );
    // The pump step ends; the rest (the wait, the pump off) is skipped: the return to idle is next.
    match r.step_done(1, ms(2000)).as_slice() {
        [RunEffect::StartStep {
            index: 4,
            step: PlanStep::ReturnToIdle { command, .. },
            ..
        }] => {
            assert_eq!(
                command,
                &group(json!({ "valve": { "V1": 0, "V2": 0 }, "pump": { "P1": false } }))
            );
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        r.step_done(2, ms(3000)),
        vec![RunEffect::Release {
            operation: "fill".into()
        }]
    );
    let stopped = serde_json::to_value(r.released(ms(3100))).unwrap();
    assert_eq!(stopped[0]["kind"], "stopped");
    assert_eq!(stopped[0]["code"], "OPERATION_STOPPED");
    assert_eq!(stopped[0]["step"], 1);
    assert_eq!(
        stopped[0]["message"],
        "operation 'fill' was stopped by an operator at step 2 (command); what it commanded is back at idle and its lines are released"
    );
    assert_eq!(r.state(), State::Stopped);
    assert_eq!(r.commands(), [Command::Reset]);
}

#[test]
fn a_stop_now_cuts_the_step_short() {
    let mut r = OperationRun::of(&plant("now"), "fill").unwrap();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(0));
    let effects = cmd(&mut r, Command::Stop, 500);
    assert!(
        matches!(
            effects.as_slice(),
            [
                RunEffect::CancelStep {
                    index: 0,
                    attempt: 0
                },
                RunEffect::Entered {
                    state: State::Stopping,
                    ..
                },
                RunEffect::StartStep {
                    index: 4,
                    attempt: 1,
                    ..
                }
            ]
        ),
        "{effects:?}"
    );
}

#[test]
fn an_abort_locks_the_lines_out_at_once_and_waits_for_a_reset() {
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(0));
    r.step_done(0, ms(1000));
    let aborted = serde_json::to_value(cmd(&mut r, Command::Abort, 1500)).unwrap();
    assert_eq!(
        aborted,
        json!([
            { "kind": "cancelStep", "index": 1, "attempt": 1 },
            { "kind": "entered", "state": "aborting", "step": null },
            { "kind": "fault", "operation": "fill", "note": "aborted by ana: gasket check" }
        ])
    );
    let end = serde_json::to_value(r.fault_applied(vec!["YEL".into()], ms(1501))).unwrap();
    assert_eq!(end[0]["code"], "ABORTED");
    assert_eq!(end[0]["state"], "aborted");
    assert_eq!(
        end[0]["message"],
        "operation 'fill' was aborted at step 2 (command): aborted by ana: gasket check; YEL locked out until cleared"
    );
    for c in [
        Command::Start,
        Command::Hold,
        Command::Restart,
        Command::Stop,
        Command::Abort,
    ] {
        assert!(r.command(c, &who(), ms(2000)).is_err(), "{c}");
    }
    cmd(&mut r, Command::Reset, 3000);
    assert_eq!(r.state(), State::Idle);
    assert_eq!(
        cmd(&mut r, Command::Start, 4000).len(),
        1,
        "a reset run starts again"
    );
}

#[test]
fn only_an_operators_abort_leaves_its_operation_awaiting_a_reset() {
    // Aborted while queued, running, held, or while a stop released: it waits for a reset.
    for state in [State::Aborting, State::Aborted] {
        for (how, r) in ways(state) {
            assert!(r.awaits_reset(), "{how}");
        }
    }
    // Its supervisor gone, a run ends aborted too, but nobody aborted it.
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(0));
    r.interrupt("its interlock left the flows", ms(10));
    r.fault_applied(vec!["YEL".into()], ms(11));
    assert_eq!(r.state(), State::Aborted);
    assert!(!r.awaits_reset());
    // Any other command, and the reset that ends the wait.
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(0));
    cmd(&mut r, Command::Stop, 20);
    assert!(!r.awaits_reset());
    cmd(&mut r, Command::Abort, 30);
    assert!(r.awaits_reset());
    r.fault_applied(Vec::new(), ms(31));
    cmd(&mut r, Command::Reset, 40);
    assert!(!r.awaits_reset());
}

#[test]
fn a_held_run_comes_back_held_after_a_restart_on_the_same_plan_only() {
    let mut r = run();
    cmd(&mut r, Command::Start, 0);
    r.granted(ms(100));
    r.step_done(0, ms(1000));
    r.step_done(1, ms(2000));
    assert!(r.snapshot(None).is_none(), "a running run is not saved");
    cmd(&mut r, Command::Hold, 12_000);
    let holding = r
        .snapshot(Some(RunOwner::Routine { id: "truck".into() }))
        .unwrap();
    assert!(!holding.held);
    r.hold_done(cur(&r), ms(13_000));
    let saved = r
        .snapshot(Some(RunOwner::Node { id: "n1".into() }))
        .unwrap();
    assert!(saved.held);
    assert_eq!(
        (saved.step, saved.used_ms, saved.held_since_ms),
        (2, ms(10_000), ms(12_000))
    );

    let plan = plant("finish-step").operation_plan("fill").unwrap();
    let (mut back, effects) = OperationRun::restore(plan.clone(), &saved).unwrap();
    assert!(effects.is_empty(), "held, it commands nothing");
    assert_eq!((back.state(), back.step()), (State::Held, Some(2)));
    // Still holding at the save: the hold command goes out again.
    let (again, effects) = OperationRun::restore(plan.clone(), &holding).unwrap();
    assert_eq!(again.state(), State::Holding);
    assert!(matches!(
        effects.as_slice(),
        [RunEffect::Entered { .. }, RunEffect::Hold { .. }]
    ));
    // It goes on as it would have.
    cmd(&mut back, Command::Restart, 20_000);
    back.restart_done(cur(&back), ms(21_000));
    back.step_done(cur(&back), ms(22_000));
    back.step_done(cur(&back), ms(23_000));
    back.step_done(cur(&back), ms(24_000));
    assert!(matches!(
        back.released(ms(25_000)).as_slice(),
        [RunEffect::Finished { .. }]
    ));

    // Another plan (the wait changed) refuses it: its lines come back faulted instead.
    let mut other = plan;
    if let PlanStep::Wait { timeout_ms, .. } = &mut other.steps[2] {
        *timeout_ms = ms(1);
    }
    let err = OperationRun::restore(other, &saved).unwrap_err();
    assert_eq!(err.code(), Code::InvalidSnapshot);
    assert_eq!(
        err.to_string(),
        "operation 'fill' was held when the state was saved but cannot come back held: the operation in the plant document changed since"
    );
}
