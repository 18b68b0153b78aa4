//! An operation's run, input by input: each transition, each message word for
//! word, late and repeated inputs ignored, and the effects as JS reads them.

use serde_json::json;
use sugarshack_core::operation::{
    OperationPlan, OperationRun, PlanStep, RunEffect, Stage, StepKind, StepRecord,
};
use sugarshack_core::plant::{GroupCommand, Plant, PlantModel, RestartRule, StopRule};
use sugarshack_core::procedure::State;
use sugarshack_core::time::ms;

/// A group command as a plant document writes it.
fn group(written: serde_json::Value) -> GroupCommand {
    serde_json::from_value(written).expect("a group command")
}

fn lines() -> Vec<String> {
    vec!["YEL".into(), "RED".into()]
}

/// Operation 10: two commands, a wait (step 3), then the return to idle.
fn plan() -> OperationPlan {
    OperationPlan {
        id: "10".into(),
        priority: 20,
        resources: lines(),
        steps: vec![
            PlanStep::Command {
                command: group(json!({ "valves": { "V1": 100 } })),
                timeout_ms: ms(9000),
                restart: RestartRule::Reissue,
            },
            PlanStep::Command {
                command: group(json!({ "valves": { "V9": 100 } })),
                timeout_ms: ms(9000),
                restart: RestartRule::Reissue,
            },
            PlanStep::Wait {
                condition: "`LT-3` > 100".into(),
                sensors: vec!["LT-3".into()],
                timeout_ms: ms(60000),
                restart: RestartRule::Rerun,
            },
            PlanStep::ReturnToIdle {
                command: group(json!({ "valve": { "V1": 0, "V9": 0 } })),
                timeout_ms: ms(9000),
            },
        ],
        hold: None,
        stop: StopRule::FinishStep,
    }
}

fn run() -> OperationRun {
    OperationRun::new(plan())
}

/// A run granted at `t = 1000` after a start at 0, running step 0.
fn granted() -> OperationRun {
    let mut r = run();
    r.start(ms(0)).unwrap();
    r.granted(ms(1000));
    r
}

/// A run at its step `index` (the earlier ones done one second apart).
fn at_step(index: usize) -> OperationRun {
    let mut r = granted();
    for i in 0..index {
        assert_eq!(r.step_done(i as u32, ms(2000 + 1000 * i as u64)).len(), 1);
    }
    assert_eq!(r.step(), Some(index));
    r
}

fn failed(effects: &[RunEffect]) -> (&str, &str, Option<usize>, Stage, &[String], bool) {
    match effects {
        [RunEffect::Failed {
            code,
            message,
            step,
            stage,
            locked_out,
            aborted,
            ..
        }] => (code, message, *step, *stage, locked_out, *aborted),
        other => panic!("expected one Failed, got {other:?}"),
    }
}

#[test]
fn start_requests_the_lines_at_the_operations_priority() {
    let mut r = run();
    assert_eq!(r.state(), State::Idle);
    assert_eq!(r.id(), "10");
    assert_eq!(
        r.start(ms(5)).unwrap(),
        vec![RunEffect::Acquire {
            operation: "10".into(),
            priority: 20,
            resources: lines(),
        }]
    );
    assert_eq!(r.state(), State::Queued);
    assert_eq!(r.step(), None);
}

#[test]
fn a_second_start_is_refused_in_every_phase() {
    let mut r = run();
    r.start(ms(0)).unwrap();
    let err = r.start(ms(1)).unwrap_err();
    assert_eq!(err.code(), "ALREADY_STARTED");
    assert_eq!(
        err.to_string(),
        "this run of operation '10' was already started (it is queued); make a new run for each start"
    );
    r.granted(ms(2));
    assert_eq!(r.start(ms(3)).unwrap_err().code(), "ALREADY_STARTED");
    assert_eq!(r.state(), State::Running);
    assert_eq!(r.step(), Some(0));
}

#[test]
fn the_grant_starts_step_0_with_the_lines_as_within() {
    let mut r = run();
    r.start(ms(0)).unwrap();
    assert_eq!(
        r.granted(ms(1000)),
        vec![RunEffect::StartStep {
            index: 0,
            attempt: 0,
            step: plan().steps[0].clone(),
            within: Some(lines()),
            timeout_ms: ms(9000),
        }]
    );
    assert_eq!((r.state(), r.step()), (State::Running, Some(0)));
    assert!(r.granted(ms(1001)).is_empty(), "a second grant is ignored");
    assert_eq!(r.step(), Some(0));
}

#[test]
fn a_wait_step_has_no_within_and_the_return_to_idle_has() {
    let mut r = at_step(1);
    assert_eq!(
        r.step_done(1, ms(5000)),
        vec![RunEffect::StartStep {
            index: 2,
            attempt: 2,
            step: plan().steps[2].clone(),
            within: None,
            timeout_ms: ms(60000),
        }]
    );
    assert_eq!(
        r.step_done(2, ms(6000)),
        vec![RunEffect::StartStep {
            index: 3,
            attempt: 3,
            step: plan().steps[3].clone(),
            within: Some(lines()),
            timeout_ms: ms(9000),
        }]
    );
}

#[test]
fn after_the_last_step_the_lines_are_released_and_the_run_finishes() {
    let mut r = granted();
    r.step_done(0, ms(1500));
    r.step_done(1, ms(4000));
    r.step_done(2, ms(4000));
    assert_eq!(
        r.step_done(3, ms(7000)),
        vec![RunEffect::Release {
            operation: "10".into()
        }]
    );
    assert_eq!((r.state(), r.step()), (State::Completing, None));
    assert_eq!(
        r.released(ms(7200)),
        vec![RunEffect::Finished {
            id: "10".into(),
            queued_ms: ms(1000),
            run_ms: ms(6200),
            held_ms: ms(0),
            steps: vec![
                StepRecord {
                    kind: StepKind::Command,
                    ms: ms(500)
                },
                StepRecord {
                    kind: StepKind::Command,
                    ms: ms(2500)
                },
                StepRecord {
                    kind: StepKind::Wait,
                    ms: ms(0)
                },
                StepRecord {
                    kind: StepKind::ReturnToIdle,
                    ms: ms(3000)
                },
            ],
        }]
    );
    assert_eq!(r.state(), State::Complete);
    assert!(r.state().is_final());
}

#[test]
fn a_plan_without_steps_releases_on_the_grant() {
    let mut r = OperationRun::new(OperationPlan {
        steps: Vec::new(),
        ..plan()
    });
    r.start(ms(10)).unwrap();
    assert_eq!(
        r.granted(ms(20)),
        vec![RunEffect::Release {
            operation: "10".into()
        }]
    );
    assert_eq!(
        r.released(ms(25)),
        vec![RunEffect::Finished {
            id: "10".into(),
            queued_ms: ms(10),
            run_ms: ms(5),
            held_ms: ms(0),
            steps: Vec::new(),
        }]
    );
}

#[test]
fn late_duplicated_and_out_of_order_inputs_are_ignored() {
    let mut r = at_step(2);
    assert!(r.step_done(1, ms(9000)).is_empty(), "a late done of step 1");
    assert!(
        r.step_done(3, ms(9000)).is_empty(),
        "a done of a step not started"
    );
    assert!(r.step_done(u32::MAX, ms(9000)).is_empty());
    assert!(r.step_failed(0, "TIMEOUT", "late", ms(9000)).is_empty());
    assert!(r.step_failed(99, "TIMEOUT", "unknown", ms(9000)).is_empty());
    assert!(r.released(ms(9000)).is_empty(), "nothing was released");
    assert!(r.release_failed("NOT_HOLDING", "x", ms(9000)).is_empty());
    assert!(r.fault_applied(lines(), ms(9000)).is_empty());
    assert!(r.refused("QUEUE_FULL", "x").is_empty());
    assert!(r.withdrawn(ms(9000)).is_empty());
    assert_eq!((r.state(), r.step()), (State::Running, Some(2)));
    // The run goes on exactly as before.
    assert_eq!(r.step_done(2, ms(9000)).len(), 1);
    assert_eq!(r.step(), Some(3));
}

#[test]
fn inputs_before_the_start_are_ignored() {
    let mut r = run();
    assert!(r.granted(ms(0)).is_empty());
    assert!(r.refused("ALREADY_HOLDING", "x").is_empty());
    assert!(r.interrupt("closed", ms(0)).is_empty());
    assert!(r.step_done(0, ms(0)).is_empty());
    assert_eq!(r.state(), State::Idle);
    assert_eq!(r.start(ms(0)).unwrap().len(), 1);
}

#[test]
fn a_failed_step_faults_the_operation_then_reports_the_lines_locked_out() {
    let mut r = at_step(2);
    let cause = "condition `LT-3` > 100 did not hold within 60 s";
    assert_eq!(
        r.step_failed(2, "CONDITION_TIMEOUT", cause, ms(70000)),
        vec![RunEffect::Fault {
            operation: "10".into(),
            note: format!("step 3 (wait): {cause}"),
        }]
    );
    assert_eq!((r.state(), r.step()), (State::Faulting, None));
    assert!(r.step_done(2, ms(70001)).is_empty(), "the step's late done");
    assert!(
        r.interrupt("closed", ms(70001)).is_empty(),
        "already faulting"
    );
    let effects = r.fault_applied(lines(), ms(70002));
    assert_eq!(
        failed(&effects),
        (
            "CONDITION_TIMEOUT",
            "operation '10' faulted at step 3 (wait): condition `LT-3` > 100 did not hold within 60 s; YEL, RED locked out until cleared",
            Some(2),
            Stage::Wait,
            &lines()[..],
            false
        )
    );
    assert_eq!(r.state(), State::Faulted);
    assert!(
        r.fault_applied(lines(), ms(70003)).is_empty(),
        "reported once"
    );
}

#[test]
fn each_step_kind_is_named_in_the_note() {
    let notes: Vec<String> = (0..4)
        .map(|i| {
            let mut r = at_step(i);
            match r.step_failed(i as u32, "E", "m", ms(0)).as_slice() {
                [RunEffect::Fault { note, .. }] => note.clone(),
                other => panic!("{other:?}"),
            }
        })
        .collect();
    assert_eq!(
        notes,
        [
            "step 1 (command): m",
            "step 2 (command): m",
            "step 3 (wait): m",
            "step 4 (return to idle): m"
        ]
    );
}

#[test]
fn nothing_locked_out_leaves_the_locked_out_part_away() {
    let mut r = at_step(0);
    r.step_failed(0, "OUTSIDE_RESOURCES", "V9 is on RED", ms(10));
    let effects = r.fault_applied(Vec::new(), ms(11));
    let (code, message, step, stage, locked_out, _) = failed(&effects);
    assert_eq!(code, "OUTSIDE_RESOURCES");
    assert_eq!(
        message,
        "operation '10' faulted at step 1 (command): V9 is on RED"
    );
    assert_eq!(
        (step, stage, locked_out.len()),
        (Some(0), Stage::Command, 0)
    );
}

#[test]
fn a_refused_fault_ends_the_run_faulted_with_nothing_locked_out() {
    let mut r = at_step(0);
    r.step_failed(0, "OUTSIDE_RESOURCES", "V9 is on RED", ms(10));
    let effects = r.fault_refused(ms(11));
    let (code, message, step, stage, locked_out, aborted) = failed(&effects);
    assert_eq!(
        (code, message, step, stage, locked_out.len(), aborted),
        (
            "OUTSIDE_RESOURCES",
            "operation '10' faulted at step 1 (command): V9 is on RED",
            Some(0),
            Stage::Command,
            0,
            false
        )
    );
    assert_eq!(r.state(), State::Faulted);
    // Not faulting, there is no fault to refuse.
    let mut r = at_step(0);
    assert!(r.fault_refused(ms(11)).is_empty());
    assert_eq!(r.state(), State::Running);
}

#[test]
fn a_failed_release_faults_the_operation_at_its_release() {
    let mut r = at_step(3);
    assert_eq!(r.step_done(3, ms(8000)).len(), 1);
    assert!(
        r.interrupt("closed", ms(8000)).is_empty(),
        "a release under way goes on"
    );
    assert_eq!(
        r.release_failed("NOT_HOLDING", "operation '10' holds nothing", ms(8001)),
        vec![RunEffect::Fault {
            operation: "10".into(),
            note: "its release: operation '10' holds nothing".into(),
        }]
    );
    assert!(r.released(ms(8002)).is_empty());
    let effects = r.fault_applied(vec!["YEL".into()], ms(8003));
    assert_eq!(
        failed(&effects),
        (
            "NOT_HOLDING",
            "operation '10' faulted at its release: operation '10' holds nothing; YEL locked out until cleared",
            None,
            Stage::Release,
            &["YEL".to_string()][..],
            false
        )
    );
}

#[test]
fn c1_refusals_become_operation_running() {
    for code in ["ALREADY_HOLDING", "ALREADY_QUEUED"] {
        let mut r = run();
        r.start(ms(0)).unwrap();
        let effects = r.refused(code, "operation '10' already holds YEL");
        assert_eq!(
            failed(&effects),
            (
                "OPERATION_RUNNING",
                "operation '10' is already running (C1: one instance at a time); this start was refused and the running one goes on",
                None,
                Stage::Acquire,
                &[][..],
                false
            )
        );
        assert_eq!(r.state(), State::Refused);
        assert!(r.granted(ms(1)).is_empty(), "nothing after the end");
    }
}

#[test]
fn other_refusals_keep_the_interlocks_words() {
    let mut r = run();
    r.start(ms(0)).unwrap();
    let effects = r.refused("QUEUE_FULL", "the queue is full (64 requests)");
    let (code, message, ..) = failed(&effects);
    assert_eq!(
        (code, message),
        ("QUEUE_FULL", "the queue is full (64 requests)")
    );
}

#[test]
fn an_interrupt_while_queued_withdraws_the_request() {
    let mut r = run();
    r.start(ms(0)).unwrap();
    assert_eq!(
        r.interrupt("its node closed", ms(5)),
        vec![RunEffect::Withdraw {
            operation: "10".into()
        }]
    );
    assert_eq!(r.state(), State::Withdrawing);
    assert!(r.interrupt("again", ms(6)).is_empty());
    assert!(r.refused("QUEUE_FULL", "x").is_empty());
    let effects = r.withdrawn(ms(7));
    assert_eq!(
        failed(&effects),
        (
            "ABORTED",
            "operation '10' was withdrawn from the queue (its node closed)",
            None,
            Stage::Acquire,
            &[][..],
            true
        )
    );
    assert_eq!(r.state(), State::Withdrawn);
    assert!(r.granted(ms(8)).is_empty());
    assert!(r.interrupt("late", ms(9)).is_empty());
}

#[test]
fn a_request_taken_out_of_the_queue_by_someone_else_ends_refused() {
    let mut r = run();
    r.start(ms(0)).unwrap();
    let effects = r.taken_out_of_queue(ms(5));
    assert_eq!(
        failed(&effects),
        (
            "ABORTED",
            "operation '10' was taken out of the queue (a cancel, or a fault while it waited) before it was granted",
            None,
            Stage::Acquire,
            &[][..],
            false
        )
    );
    assert_eq!(r.state(), State::Refused);
    assert!(
        r.taken_out_of_queue(ms(6)).is_empty(),
        "nothing after the end"
    );
}

/// A queued run whose node closed: it asked to be withdrawn.
fn withdrawing() -> OperationRun {
    let mut r = run();
    r.start(ms(0)).unwrap();
    r.interrupt("its node closed", ms(5));
    r
}

/// The run ended as its withdrawal says.
fn assert_withdrawn(r: &OperationRun, effects: &[RunEffect]) {
    let (code, message, ..) = failed(effects);
    assert_eq!(
        (code, message),
        (
            "ABORTED",
            "operation '10' was withdrawn from the queue (its node closed)"
        )
    );
    assert_eq!(r.state(), State::Withdrawn);
}

#[test]
fn a_request_taken_out_while_withdrawing_ends_as_its_withdrawal_says() {
    let mut r = withdrawing();
    let effects = r.taken_out_of_queue(ms(6));
    assert_withdrawn(&r, &effects);
    // Granted meanwhile, the release it handed back decides the end.
    let mut r = withdrawing();
    r.granted(ms(6));
    assert!(r.taken_out_of_queue(ms(7)).is_empty());
    assert_eq!(r.state(), State::Withdrawing);
    // Granted and running, it is not in the queue any more.
    let mut r = granted();
    assert!(r.taken_out_of_queue(ms(2000)).is_empty());
    assert_eq!(r.state(), State::Running);
}

#[test]
fn a_refused_withdrawal_ends_the_run_as_withdrawn() {
    let mut r = withdrawing();
    let effects = r.withdraw_refused(ms(6));
    assert_withdrawn(&r, &effects);
    // Queued, nothing was asked to withdraw: a refusal changes nothing.
    let mut r = run();
    r.start(ms(0)).unwrap();
    assert!(r.withdraw_refused(ms(6)).is_empty());
    assert_eq!(r.state(), State::Queued);
}

#[test]
fn a_grant_that_crossed_the_withdrawal_is_released_before_the_end() {
    let mut r = withdrawing();
    assert_eq!(
        r.granted(ms(6)),
        vec![RunEffect::Release {
            operation: "10".into()
        }]
    );
    assert!(r.granted(ms(7)).is_empty());
    assert!(
        r.withdrawn(ms(7)).is_empty(),
        "the release decides how it ends"
    );
    let effects = r.released(ms(8));
    assert_withdrawn(&r, &effects);
}

#[test]
fn a_crossing_grant_that_cannot_be_released_faults_the_operation() {
    let mut r = withdrawing();
    r.granted(ms(6));
    assert_eq!(
        r.release_failed("NOT_HOLDING", "gone", ms(7)),
        vec![RunEffect::Fault {
            operation: "10".into(),
            note: "its release: gone".into(),
        }]
    );
    let effects = r.fault_applied(lines(), ms(8));
    assert_eq!(
        failed(&effects),
        (
            "ABORTED",
            "operation '10' faulted at its release: gone; YEL, RED locked out until cleared",
            None,
            Stage::Release,
            &lines()[..],
            true
        )
    );
}

#[test]
fn an_interrupt_while_running_cancels_the_step_and_faults_the_operation() {
    let mut r = at_step(1);
    assert_eq!(
        r.interrupt(
            "its operation node was stopped (redeploy or shutdown)",
            ms(4000)
        ),
        vec![
            RunEffect::CancelStep {
                index: 1,
                attempt: 1
            },
            RunEffect::Fault {
                operation: "10".into(),
                note: "interrupted: its operation node was stopped (redeploy or shutdown)".into(),
            }
        ]
    );
    assert_eq!((r.state(), r.step()), (State::Aborting, None));
    // The cancelled step ends in error, late: ignored.
    assert!(r
        .step_failed(1, "ABORTED", "cancelled", ms(4001))
        .is_empty());
    let effects = r.fault_applied(vec!["YEL".into()], ms(4002));
    assert_eq!(
        failed(&effects),
        (
            "ABORTED",
            "operation '10' faulted at step 2 (command): interrupted: its operation node was stopped (redeploy or shutdown); YEL locked out until cleared",
            Some(1),
            Stage::Command,
            &["YEL".to_string()][..],
            true
        )
    );
    assert!(r.interrupt("again", ms(4003)).is_empty());
}

#[test]
fn a_clock_that_goes_back_gives_zero_durations() {
    // The latest time whose whole milliseconds are all exact.
    const LATEST: u64 = 1 << 53;
    let mut r = run();
    r.start(ms(LATEST)).unwrap();
    r.granted(ms(10));
    r.step_done(0, ms(5));
    let mut r2 = OperationRun::new(OperationPlan {
        steps: Vec::new(),
        ..plan()
    });
    r2.start(ms(100)).unwrap();
    r2.granted(ms(50));
    assert_eq!(
        r2.released(ms(0)),
        vec![RunEffect::Finished {
            id: "10".into(),
            queued_ms: ms(0),
            run_ms: ms(0),
            held_ms: ms(0),
            steps: Vec::new(),
        }]
    );
    for i in 1..4 {
        r.step_done(i, ms(LATEST));
    }
    match r.released(ms(LATEST)).as_slice() {
        [RunEffect::Finished {
            queued_ms,
            run_ms,
            steps,
            ..
        }] => {
            assert_eq!((*queued_ms, *run_ms), (ms(0), ms(LATEST - 10)));
            assert_eq!(
                steps.iter().map(|s| s.ms).collect::<Vec<_>>(),
                [ms(0), ms(LATEST - 5), ms(0), ms(0)]
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn effects_serialize_as_js_reads_them() {
    let mut r = run();
    let acquire = serde_json::to_value(r.start(ms(0)).unwrap()).unwrap();
    assert_eq!(
        acquire,
        json!([{ "kind": "acquire", "operation": "10", "priority": 20, "resources": ["YEL", "RED"] }])
    );
    let start = serde_json::to_value(r.granted(ms(1))).unwrap();
    assert_eq!(
        start,
        json!([{ "kind": "startStep", "index": 0, "attempt": 0, "within": ["YEL", "RED"],
                 "timeoutMs": 9000,
                 "step": { "kind": "command", "command": { "valves": { "V1": 100 } }, "timeoutMs": 9000, "restart": "reissue" } }])
    );
    r.step_done(0, ms(2));
    let wait = serde_json::to_value(r.step_done(1, ms(3))).unwrap();
    assert_eq!(
        wait,
        json!([{ "kind": "startStep", "index": 2, "attempt": 2,
                 "timeoutMs": 60000,
                 "step": { "kind": "wait", "condition": "`LT-3` > 100", "sensors": ["LT-3"], "timeoutMs": 60000, "restart": "rerun" } }])
    );
    let abort = serde_json::to_value(r.interrupt("closed", ms(4))).unwrap();
    assert_eq!(
        abort,
        json!([{ "kind": "cancelStep", "index": 2, "attempt": 2 },
               { "kind": "fault", "operation": "10", "note": "interrupted: closed" }])
    );
    let end = serde_json::to_value(r.fault_applied(vec!["YEL".into()], ms(5))).unwrap();
    assert_eq!(
        end,
        json!([{ "kind": "failed", "id": "10", "code": "ABORTED",
                 "message": "operation '10' faulted at step 3 (wait): interrupted: closed; YEL locked out until cleared",
                 "step": 2, "stage": "wait", "lockedOut": ["YEL"], "aborted": true, "state": "aborted" }])
    );

    let mut r = granted();
    for i in 0..4 {
        r.step_done(i, ms(1000));
    }
    assert_eq!(
        serde_json::to_value(r.released(ms(1000))).unwrap(),
        json!([{ "kind": "finished", "id": "10", "queuedMs": 1000, "runMs": 0, "heldMs": 0,
                 "steps": [{ "kind": "command", "ms": 0 }, { "kind": "command", "ms": 0 },
                           { "kind": "wait", "ms": 0 }, { "kind": "returnToIdle", "ms": 0 }] }])
    );
    let mut r = run();
    r.start(ms(0)).unwrap();
    assert_eq!(
        serde_json::to_value(r.interrupt("closed", ms(0))).unwrap(),
        json!([{ "kind": "withdraw", "operation": "10" }])
    );
    assert_eq!(
        serde_json::to_value(r.withdrawn(ms(0))).unwrap()[0]["step"],
        json!(null)
    );
    assert_eq!(
        serde_json::to_value(State::Withdrawing).unwrap(),
        "withdrawing"
    );
}

#[test]
fn a_run_of_a_plant_operation_ends_with_its_return_to_idle() {
    let plant: PlantModel = serde_json::from_value(json!({
        "actuatorTypes": {
            "valve": { "signal": "analog", "noMotionMs": 1000, "completionMs": 6000, "staleMs": 3000 }
        },
        "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }],
        "actuators": [
            { "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "idle": 0, "lockout": 0, "resource": "YEL" }
        ],
        "resources": [{ "id": "YEL" }],
        "operations": [{ "id": "10", "priority": 20, "resources": ["YEL"],
            "steps": [{ "command": { "valves": { "V1": 100 } }, "timeoutMs": 20000 }] }]
    }))
    .unwrap();
    let plant = Plant::new(plant).unwrap();
    let mut r = OperationRun::of(&plant, "10").unwrap();
    assert_eq!(r.plan(), &plant.operation_plan("10").unwrap());
    r.start(ms(0)).unwrap();
    r.granted(ms(0));
    match r.step_done(0, ms(1)).as_slice() {
        [RunEffect::StartStep {
            index: 1,
            attempt: 1,
            step: PlanStep::ReturnToIdle { command, .. },
            within: Some(within),
            ..
        }] => {
            assert_eq!(command, &group(json!({ "valve": { "V1": 0 } })));
            assert_eq!(within, &["YEL".to_string()]);
        }
        other => panic!("{other:?}"),
    }

    let err = OperationRun::of(&plant, "99").unwrap_err();
    assert_eq!(err.code(), "UNKNOWN_OPERATION");
    assert_eq!(
        err.to_string(),
        "unknown operation '99': it is not in the plant document"
    );
    let long = "x".repeat(500);
    let message = OperationRun::of(&plant, &long).unwrap_err().to_string();
    assert!(message.contains(&format!("'{}…'", "x".repeat(99))));
    assert!(message.len() < 200);
}
