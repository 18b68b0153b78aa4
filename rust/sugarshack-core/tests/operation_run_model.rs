//! An operation's run against a simple reference model: random plans (waits,
//! with or without commands) and random inputs, late, repeated and out of
//! order, aborts at any time, a clock that may jump back. Every input's effects
//! equal the model's, and the whole stream follows the run's grammar.

use proptest::prelude::*;
use serde_json::json;
use sugarshack_core::operation::{
    OperationPlan, OperationRun, PlanStep, RunEffect, Stage, StepKind, StepRecord,
};
use sugarshack_core::plant::{GroupCommand, RestartRule, StopRule};
use sugarshack_core::procedure::State;
use sugarshack_core::time::{ms, Millis};

/// A group command as a plant document writes it.
fn group(written: serde_json::Value) -> GroupCommand {
    serde_json::from_value(written).expect("a group command")
}

const ID: &str = "op";
const LINES: [&str; 2] = ["YEL", "RED"];

/// Steps as written (true: a command, false: a wait); a return to idle is
/// appended when any commands, as the plant's plans do.
fn plan(commands: &[bool]) -> OperationPlan {
    let mut steps: Vec<PlanStep> = commands
        .iter()
        .enumerate()
        .map(|(i, &command)| {
            if command {
                PlanStep::Command {
                    command: group(json!({ "valves": { format!("V{i}"): 100 } })),
                    timeout_ms: ms(1000 + i as u64),
                    restart: RestartRule::Reissue,
                }
            } else {
                PlanStep::Wait {
                    condition: "`S` > 1".into(),
                    sensors: vec!["S".into()],
                    timeout_ms: ms(2000 + i as u64),
                    restart: RestartRule::Rerun,
                }
            }
        })
        .collect();
    if commands.contains(&true) {
        steps.push(PlanStep::ReturnToIdle {
            command: group(json!({ "valve": {} })),
            timeout_ms: ms(3000),
        });
    }
    OperationPlan {
        id: ID.into(),
        priority: 7,
        resources: LINES.iter().map(|l| l.to_string()).collect(),
        steps,
        hold: None,
        stop: StopRule::FinishStep,
    }
}

/// Which step an input names, relative to the one in progress.
#[derive(Clone, Copy, Debug)]
enum Which {
    Current,
    Previous,
    Next,
    Index(usize),
}

#[derive(Clone, Debug)]
enum Input {
    Start,
    Granted,
    StepDone(Which),
    StepFailed(Which),
    Released,
    ReleaseFailed,
    FaultApplied(usize),
    Refused(&'static str),
    Abort,
    Withdrawn,
    TakenOut,
    FaultRefused,
    WithdrawRefused,
}

#[derive(Clone, Copy, Debug)]
enum Clock {
    Ahead(u64),
    Back(u64),
    Anywhere(u64),
}

fn which() -> impl Strategy<Value = Which> {
    prop_oneof![
        6 => Just(Which::Current),
        1 => Just(Which::Previous),
        1 => Just(Which::Next),
        1 => (0..9usize).prop_map(Which::Index),
    ]
}

fn input() -> impl Strategy<Value = Input> {
    prop_oneof![
        2 => Just(Input::Start),
        3 => Just(Input::Granted),
        10 => which().prop_map(Input::StepDone),
        1 => which().prop_map(Input::StepFailed),
        3 => Just(Input::Released),
        1 => Just(Input::ReleaseFailed),
        3 => (0..3usize).prop_map(Input::FaultApplied),
        1 => prop::sample::select(vec!["ALREADY_HOLDING", "ALREADY_QUEUED", "QUEUE_FULL"]).prop_map(Input::Refused),
        1 => Just(Input::Abort),
        2 => Just(Input::Withdrawn),
        1 => Just(Input::TakenOut),
        1 => Just(Input::FaultRefused),
        1 => Just(Input::WithdrawRefused),
    ]
}

/// The latest time the facade accepts (Number.MAX_SAFE_INTEGER ms): up to
/// it every whole millisecond is exact.
const LATEST: u64 = (1 << 53) - 1;

fn clock() -> impl Strategy<Value = Clock> {
    prop_oneof![
        8 => (0..5000u64).prop_map(Clock::Ahead),
        1 => (0..5000u64).prop_map(Clock::Back),
        1 => (0..=LATEST).prop_map(Clock::Anywhere),
    ]
}

/// The reference: what the run has done so far, as flags, read against the
/// task's description of each input.
#[derive(Default)]
struct Model {
    steps: Vec<PlanStep>,
    started_at: Option<u64>,
    granted_at: Option<u64>,
    /// The abort reason, once withdrawal was asked while queued.
    withdrawing: Option<String>,
    handed_back: bool,
    /// The step in progress and when it started.
    current: Option<(usize, u64)>,
    releasing: bool,
    /// While the fault is applied.
    fault: Option<Fault>,
    ended: bool,
    records: Vec<StepRecord>,
}

struct Fault {
    code: String,
    place: String,
    cause: String,
    step: Option<usize>,
    stage: Stage,
    aborted: bool,
}

fn kind(step: &PlanStep) -> (StepKind, Stage, &'static str) {
    match step {
        PlanStep::Command { .. } => (StepKind::Command, Stage::Command, "command"),
        PlanStep::Wait { .. } => (StepKind::Wait, Stage::Wait, "wait"),
        PlanStep::ReturnToIdle { .. } => (
            StepKind::ReturnToIdle,
            Stage::ReturnToIdle,
            "return to idle",
        ),
    }
}

fn failed(
    code: &str,
    message: String,
    step: Option<usize>,
    stage: Stage,
    locked_out: Vec<String>,
    aborted: bool,
    state: State,
) -> RunEffect {
    RunEffect::Failed {
        id: ID.into(),
        code: code.into(),
        message,
        step,
        stage,
        locked_out,
        aborted,
        state,
    }
}

impl Model {
    fn start_step(&mut self, index: usize, now: u64) -> Vec<RunEffect> {
        if index == self.steps.len() {
            self.current = None;
            self.releasing = true;
            return vec![RunEffect::Release {
                operation: ID.into(),
            }];
        }
        self.current = Some((index, now));
        let step = self.steps[index].clone();
        let within = (!matches!(step, PlanStep::Wait { .. }))
            .then(|| LINES.iter().map(|l| l.to_string()).collect());
        let timeout_ms = step.timeout_ms();
        // No hold here: each step is tried once, and its attempt is its index.
        vec![RunEffect::StartStep {
            index,
            attempt: index as u32,
            step,
            within,
            timeout_ms,
        }]
    }

    fn withdrawn_failure(&mut self) -> Vec<RunEffect> {
        self.ended = true;
        let reason = self.withdrawing.clone().unwrap_or_default();
        vec![failed(
            "ABORTED",
            format!("operation '{ID}' was withdrawn from the queue ({reason})"),
            None,
            Stage::Acquire,
            Vec::new(),
            true,
            State::Withdrawn,
        )]
    }

    fn apply(&mut self, input: &Input, index: Option<usize>, now: u64) -> Vec<RunEffect> {
        if self.ended {
            return Vec::new();
        }
        let queued =
            self.started_at.is_some() && self.granted_at.is_none() && self.withdrawing.is_none();
        match input {
            Input::Start => unreachable!("checked by the caller"),
            Input::Granted if queued => {
                self.granted_at = Some(now);
                self.start_step(0, now)
            }
            Input::Granted if self.withdrawing.is_some() && !self.handed_back => {
                self.handed_back = true;
                vec![RunEffect::Release {
                    operation: ID.into(),
                }]
            }
            Input::StepDone(_) => match self.current {
                Some((i, since)) if Some(i) == index && self.fault.is_none() => {
                    self.records.push(StepRecord {
                        kind: kind(&self.steps[i]).0,
                        ms: ms(now.saturating_sub(since)),
                    });
                    self.start_step(i + 1, now)
                }
                _ => Vec::new(),
            },
            Input::StepFailed(_) => match self.current {
                Some((i, _)) if Some(i) == index && self.fault.is_none() => {
                    let (_, stage, words) = kind(&self.steps[i]);
                    let place = format!("step {} ({words})", i + 1);
                    self.current = None;
                    self.fault = Some(Fault {
                        code: "E_STEP".into(),
                        place: place.clone(),
                        cause: "it broke".into(),
                        step: Some(i),
                        stage,
                        aborted: false,
                    });
                    vec![RunEffect::Fault {
                        operation: ID.into(),
                        note: format!("{place}: it broke"),
                    }]
                }
                _ => Vec::new(),
            },
            Input::Released if self.releasing && self.fault.is_none() => {
                self.releasing = false;
                self.ended = true;
                let granted = self.granted_at.unwrap_or_default();
                vec![RunEffect::Finished {
                    id: ID.into(),
                    queued_ms: ms(granted.saturating_sub(self.started_at.unwrap_or_default())),
                    run_ms: ms(now.saturating_sub(granted)),
                    held_ms: Millis::ZERO,
                    steps: std::mem::take(&mut self.records),
                }]
            }
            Input::Released if self.handed_back && self.fault.is_none() => self.withdrawn_failure(),
            Input::ReleaseFailed
                if (self.releasing || self.handed_back) && self.fault.is_none() =>
            {
                self.fault = Some(Fault {
                    code: "E_RELEASE".into(),
                    place: "its release".into(),
                    cause: "not held".into(),
                    step: None,
                    stage: Stage::Release,
                    aborted: self.handed_back,
                });
                vec![RunEffect::Fault {
                    operation: ID.into(),
                    note: "its release: not held".into(),
                }]
            }
            Input::FaultRefused => self.apply(&Input::FaultApplied(0), index, now),
            Input::WithdrawRefused => self.apply(&Input::Withdrawn, index, now),
            Input::FaultApplied(n) => match self.fault.take() {
                Some(Fault {
                    code,
                    place,
                    cause,
                    step,
                    stage,
                    aborted,
                }) => {
                    self.ended = true;
                    let lines: Vec<String> = LINES[..*n.min(&LINES.len())]
                        .iter()
                        .map(|l| l.to_string())
                        .collect();
                    let mut message = format!("operation '{ID}' faulted at {place}: {cause}");
                    if !lines.is_empty() {
                        message += &format!("; {} locked out until cleared", lines.join(", "));
                    }
                    vec![failed(
                        if aborted { "ABORTED" } else { &code },
                        message,
                        step,
                        stage,
                        lines,
                        aborted,
                        if aborted {
                            State::Aborted
                        } else {
                            State::Faulted
                        },
                    )]
                }
                None => Vec::new(),
            },
            Input::Refused(code) if queued => {
                self.ended = true;
                if *code == "QUEUE_FULL" {
                    vec![failed(
                        code,
                        "the queue is full".into(),
                        None,
                        Stage::Acquire,
                        Vec::new(),
                        false,
                        State::Refused,
                    )]
                } else {
                    let message = format!("operation '{ID}' is already running (C1: one instance at a time); this start was refused and the running one goes on");
                    vec![failed(
                        "OPERATION_RUNNING",
                        message,
                        None,
                        Stage::Acquire,
                        Vec::new(),
                        false,
                        State::Refused,
                    )]
                }
            }
            Input::Abort if queued => {
                self.withdrawing = Some(format!("closed at {now}"));
                vec![RunEffect::Withdraw {
                    operation: ID.into(),
                }]
            }
            Input::Abort => match self.current {
                Some((i, _)) if self.fault.is_none() => {
                    let (_, stage, words) = kind(&self.steps[i]);
                    let cause = format!("interrupted: closed at {now}");
                    self.current = None;
                    self.fault = Some(Fault {
                        code: "ignored".into(),
                        place: format!("step {} ({words})", i + 1),
                        cause: cause.clone(),
                        step: Some(i),
                        stage,
                        aborted: true,
                    });
                    vec![
                        RunEffect::CancelStep {
                            index: i,
                            attempt: i as u32,
                        },
                        RunEffect::Fault {
                            operation: ID.into(),
                            note: cause,
                        },
                    ]
                }
                _ => Vec::new(),
            },
            Input::Withdrawn if self.withdrawing.is_some() && !self.handed_back => {
                self.withdrawn_failure()
            }
            Input::TakenOut if queued => {
                self.ended = true;
                let message = format!("operation '{ID}' was taken out of the queue (a cancel, or a fault while it waited) before it was granted");
                vec![failed(
                    "ABORTED",
                    message,
                    None,
                    Stage::Acquire,
                    Vec::new(),
                    false,
                    State::Refused,
                )]
            }
            Input::TakenOut if self.withdrawing.is_some() && !self.handed_back => {
                self.withdrawn_failure()
            }
            _ => Vec::new(),
        }
    }
}

/// Where the stream of effects is in the grammar
/// `Acquire (StartStep(i) for i = 0, 1, ...)* (Release Finished | [Release] [CancelStep] Fault Failed)`,
/// `Acquire Failed` or `Acquire Withdraw [Release [Fault]] Failed`.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Grammar {
    Begin,
    Acquired,
    Withdrawing {
        handed_back: bool,
    },
    /// The last step started.
    Stepping(usize),
    Cancelled(usize),
    Releasing,
    Faulting,
    End,
}

fn follow(g: Grammar, e: &RunEffect, plan: &OperationPlan) -> Result<Grammar, String> {
    use Grammar::*;
    let n = plan.steps.len();
    let has_commands = plan
        .steps
        .iter()
        .any(|s| matches!(s, PlanStep::Command { .. }));
    let next = match (g, e) {
        (Begin, RunEffect::Acquire { .. }) => Acquired,
        (
            Acquired,
            RunEffect::Failed {
                step: None,
                stage: Stage::Acquire,
                aborted: false,
                locked_out,
                ..
            },
        ) if locked_out.is_empty() => End,
        (Acquired, RunEffect::Withdraw { .. }) => Withdrawing { handed_back: false },
        (Withdrawing { handed_back: false }, RunEffect::Release { .. }) => {
            Withdrawing { handed_back: true }
        }
        (Withdrawing { handed_back: true }, RunEffect::Fault { .. }) => Faulting,
        (
            Withdrawing { .. },
            RunEffect::Failed {
                code,
                step: None,
                stage: Stage::Acquire,
                aborted: true,
                ..
            },
        ) if code == "ABORTED" => End,
        (Acquired, RunEffect::StartStep { index: 0, .. }) => Stepping(0),
        (Stepping(k), RunEffect::StartStep { index, .. }) if *index == k + 1 => Stepping(*index),
        (Acquired, RunEffect::Release { .. }) if n == 0 => Releasing,
        (Stepping(k), RunEffect::Release { .. }) if k + 1 == n => {
            if has_commands && !matches!(plan.steps[k], PlanStep::ReturnToIdle { .. }) {
                return Err("a plan with commands released without returning to idle last".into());
            }
            Releasing
        }
        (Stepping(k), RunEffect::CancelStep { index, .. }) if *index == k => Cancelled(k),
        (Stepping(_) | Cancelled(_) | Releasing, RunEffect::Fault { .. }) => Faulting,
        (Releasing, RunEffect::Finished { .. }) => End,
        (Faulting, RunEffect::Failed { .. }) => End,
        _ => return Err(format!("{e:?} after {g:?}")),
    };
    Ok(next)
}

fn is_terminal(e: &RunEffect) -> bool {
    matches!(e, RunEffect::Finished { .. } | RunEffect::Failed { .. })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    #[test]
    fn a_run_matches_the_reference_and_its_grammar(
        commands in prop::collection::vec(any::<bool>(), 1..=6),
        inputs in prop::collection::vec((input(), clock()), 0..40),
        start_at in prop_oneof![Just(0u64), 0..=LATEST],
    ) {
        let plan = plan(&commands);
        let mut run = OperationRun::new(plan.clone());
        let mut model = Model { steps: plan.steps.clone(), ..Model::default() };
        let mut now = start_at;
        let mut monotone = true;
        let mut stream: Vec<RunEffect> = Vec::new();
        let mut grammar = Grammar::Begin;
        for (input, clock) in &inputs {
            now = match *clock {
                Clock::Ahead(dt) => now.saturating_add(dt).min(LATEST),
                Clock::Back(dt) => { monotone = false; now.saturating_sub(dt) }
                Clock::Anywhere(t) => { monotone &= t >= now; t }
            };
            let current = model.current.map(|(i, _)| i);
            let index = |w: &Which| -> usize {
                match (*w, current) {
                    (Which::Current, Some(i)) => i,
                    (Which::Previous, Some(i)) => i.wrapping_sub(1),
                    (Which::Next, Some(i)) => i + 1,
                    (Which::Index(i), _) => i,
                    (_, None) => 0,
                }
            };
            let reason = format!("closed at {now}");
            let (effects, expected) = match input {
                Input::Start => {
                    let was_new = model.started_at.is_none();
                    match run.start(ms(now)) {
                        Ok(effects) => {
                            prop_assert!(was_new, "a second start was taken");
                            model.started_at = Some(now);
                            let acquire = RunEffect::Acquire { operation: ID.into(), priority: 7, resources: plan.resources.clone() };
                            (effects, vec![acquire])
                        }
                        Err(err) => {
                            prop_assert!(!was_new, "the first start was refused: {}", err);
                            prop_assert_eq!(err.code(), "ALREADY_STARTED");
                            (Vec::new(), Vec::new())
                        }
                    }
                }
                Input::Granted => (run.granted(ms(now)), model.apply(input, None, now)),
                Input::StepDone(w) => {
                    let i = index(w);
                    (run.step_done(i as u32, ms(now)), model.apply(input, Some(i), now))
                }
                Input::StepFailed(w) => {
                    let i = index(w);
                    (run.step_failed(i as u32, "E_STEP", "it broke", ms(now)), model.apply(input, Some(i), now))
                }
                Input::Released => (run.released(ms(now)), model.apply(input, None, now)),
                Input::ReleaseFailed => (run.release_failed("E_RELEASE", "not held", ms(now)), model.apply(input, None, now)),
                Input::FaultApplied(n) => {
                    let lines = LINES[..(*n).min(LINES.len())].iter().map(|l| l.to_string()).collect();
                    (run.fault_applied(lines, ms(now)), model.apply(input, None, now))
                }
                Input::Refused(code) => {
                    let message = if *code == "QUEUE_FULL" { "the queue is full" } else { "held" };
                    (run.refused(code, message), model.apply(input, None, now))
                }
                Input::Abort => (run.interrupt(&reason, ms(now)), model.apply(input, None, now)),
                Input::Withdrawn => (run.withdrawn(ms(now)), model.apply(input, None, now)),
                Input::TakenOut => (run.taken_out_of_queue(ms(now)), model.apply(input, None, now)),
                Input::FaultRefused => (run.fault_refused(ms(now)), model.apply(input, None, now)),
                Input::WithdrawRefused => (run.withdraw_refused(ms(now)), model.apply(input, None, now)),
            };
            prop_assert_eq!(&effects, &expected, "after {:?} at {}", input, now);
            prop_assert_eq!(run.step(), model.current.map(|(i, _)| i));
            for e in &effects {
                grammar = follow(grammar, e, &plan).map_err(TestCaseError::fail)?;
                if let RunEffect::Finished { queued_ms, run_ms, steps, .. } = e {
                    if monotone {
                        let total = steps.iter().fold(Millis::ZERO, |sum, s| sum.saturating_add(s.ms));
                        prop_assert!(total <= *run_ms, "steps {:?} exceed the run {}", steps, run_ms);
                        prop_assert!(queued_ms.saturating_add(*run_ms) <= ms(now - start_at));
                    }
                }
            }
            stream.extend(effects);
        }
        let terminals = stream.iter().filter(|e| is_terminal(e)).count();
        prop_assert_eq!(terminals, usize::from(run.state().is_final()));
        prop_assert_eq!(grammar == Grammar::End, run.state().is_final());
        prop_assert_eq!(model.ended, run.state().is_final());
        // A run ended by a fault had been granted.
        if stream.iter().any(|e| matches!(e, RunEffect::Fault { .. })) {
            prop_assert!(model.granted_at.is_some() || model.handed_back);
        }
    }
}
