//! Operation runs and routines under an operator's ISA-88 commands, against
//! a simple reference model: any sequence of commands (hold, restart, stop,
//! abort, reset, start) and plant events (grants, steps done or failed, hold
//! and restart commands confirmed or failed, releases, faults applied, a
//! supervisor gone), at random times. After every input:
//!
//! - the run's state, step and effects are the model's (the effects by kind,
//!   step, timeout and attempt: a held step's timeout stands still, and each
//!   step, hold command and restore is a new attempt);
//! - an answer to an earlier attempt (a step cancelled by a hold, then
//!   reissued after the restart), interleaved anywhere, changes nothing;
//! - the move is declared: one command the table allows, then only moves
//!   events declare; a command the table refuses changes nothing;
//! - a held run commands nothing: no step, no command, no release goes out
//!   while it stays held;
//! - aborted is left only by a reset.

use proptest::prelude::*;
use serde_json::json;
use sugarshack_core::clearance::Attribution;
use sugarshack_core::operation::{OperationPlan, OperationRun, PlanStep, RunEffect};
use sugarshack_core::plant::{GroupCommand, HoldCommand, RestartRule, StopRule};
use sugarshack_core::procedure::{
    self, Command, Event, RoutineEvent, State, Verdict, OPERATION, OPERATION_EVENTS, ROUTINE_EVENTS,
};
use sugarshack_core::time::{ms, Millis};

fn group(written: serde_json::Value) -> GroupCommand {
    serde_json::from_value(written).expect("a group command")
}

const ID: &str = "fill";

/// Steps as written (true: a command of valve V{i}, false: a wait) and their
/// restart rules; a return to idle is appended, with what the hold sets (P
/// and V1) as the plan builder adds it.
fn plan(steps: &[(bool, bool)], hold: bool, stop_now: bool) -> OperationPlan {
    let mut plan_steps: Vec<PlanStep> = steps
        .iter()
        .enumerate()
        .map(|(i, &(command, rerun))| {
            let restart = if rerun {
                RestartRule::Rerun
            } else {
                RestartRule::Reissue
            };
            if command {
                PlanStep::Command {
                    command: group(json!({ "valves": { format!("V{i}"): 100 } })),
                    timeout_ms: ms(1000 + 100 * i as u64),
                    restart,
                }
            } else {
                PlanStep::Wait {
                    condition: "`S` > 1".into(),
                    sensors: vec!["S".into()],
                    timeout_ms: ms(2000 + 100 * i as u64),
                    restart,
                }
            }
        })
        .collect();
    let mut idle = serde_json::Map::new();
    for (i, &(command, _)) in steps.iter().enumerate() {
        if command {
            idle.insert(format!("V{i}"), json!(0));
        }
    }
    for id in ["V1", "P"] {
        idle.insert(id.into(), json!(0));
    }
    plan_steps.push(PlanStep::ReturnToIdle {
        command: group(json!({ "valve": idle })),
        timeout_ms: ms(3000),
    });
    OperationPlan {
        id: ID.into(),
        priority: 5,
        resources: vec!["YEL".into()],
        steps: plan_steps,
        hold: hold.then(|| HoldCommand {
            command: group(json!({ "valve": { "P": 0, "V1": 0 } })),
            timeout_ms: ms(700),
        }),
        stop: if stop_now {
            StopRule::Now
        } else {
            StopRule::FinishStep
        },
    }
}

#[derive(Clone, Copy, Debug)]
enum Input {
    Command(Command),
    Granted,
    Refused,
    Withdrawn,
    StepDone,
    StepDoneOther,
    StepFailed,
    HoldDone,
    HoldFailed,
    RestartDone,
    RestartFailed,
    Released,
    ReleaseFailed,
    FaultApplied,
    Interrupt,
    /// An answer to the attempt `n` before the latest one.
    Stale(Answer, u32),
}

/// An answer to a step, a hold command or a restore.
#[derive(Clone, Copy, Debug)]
enum Answer {
    StepDone,
    StepFailed,
    HoldDone,
    HoldFailed,
    RestartDone,
    RestartFailed,
}

fn answer() -> impl Strategy<Value = Answer> {
    prop::sample::select(vec![
        Answer::StepDone,
        Answer::StepFailed,
        Answer::HoldDone,
        Answer::HoldFailed,
        Answer::RestartDone,
        Answer::RestartFailed,
    ])
}

fn input() -> impl Strategy<Value = Input> {
    prop_oneof![
        6 => prop::sample::select(Command::ALL.to_vec()).prop_map(Input::Command),
        3 => Just(Input::Granted),
        1 => Just(Input::Refused),
        1 => Just(Input::Withdrawn),
        6 => Just(Input::StepDone),
        1 => Just(Input::StepDoneOther),
        1 => Just(Input::StepFailed),
        3 => Just(Input::HoldDone),
        1 => Just(Input::HoldFailed),
        3 => Just(Input::RestartDone),
        1 => Just(Input::RestartFailed),
        3 => Just(Input::Released),
        1 => Just(Input::ReleaseFailed),
        3 => Just(Input::FaultApplied),
        1 => Just(Input::Interrupt),
        4 => (answer(), 1..4u32).prop_map(|(a, n)| Input::Stale(a, n)),
    ]
}

/// What the model expects an effect to be, by kind and the fields that matter here.
#[derive(Clone, Debug, PartialEq)]
enum Expect {
    Acquire,
    /// Step, timeout, attempt.
    Start(usize, Millis, u32),
    /// Step, attempt.
    Cancel(usize, u32),
    Hold(u32),
    Restore(u32),
    Entered(State),
    Release,
    Withdraw,
    Fault,
    Finished(Millis),
    Stopped,
    Failed(State),
}

fn seen(e: &RunEffect) -> Expect {
    match e {
        RunEffect::Acquire { .. } => Expect::Acquire,
        RunEffect::StartStep {
            index,
            timeout_ms,
            attempt,
            ..
        } => Expect::Start(*index, *timeout_ms, *attempt),
        RunEffect::CancelStep { index, attempt } => Expect::Cancel(*index, *attempt),
        RunEffect::Hold { attempt, .. } => Expect::Hold(*attempt),
        RunEffect::Restore { attempt, .. } => Expect::Restore(*attempt),
        RunEffect::Entered { state, .. } => Expect::Entered(*state),
        RunEffect::Release { .. } => Expect::Release,
        RunEffect::Withdraw { .. } => Expect::Withdraw,
        RunEffect::Fault { .. } => Expect::Fault,
        RunEffect::Finished { held_ms, .. } => Expect::Finished(*held_ms),
        RunEffect::Stopped { .. } => Expect::Stopped,
        RunEffect::Failed { state, .. } => Expect::Failed(*state),
    }
}

/// Where the reference is, as plainly as the task describes it.
#[derive(Clone, Copy, Debug, PartialEq)]
enum At {
    Idle,
    Queued,
    /// Taking the request out of the queue; `end`: where it ends.
    Withdrawing {
        end: State,
        handed_back: bool,
    },
    Step {
        i: usize,
        stopping: bool,
    },
    Holding {
        i: usize,
    },
    Held {
        i: usize,
    },
    Restarting {
        i: usize,
    },
    Releasing {
        stop: bool,
        abort: bool,
    },
    Faulting {
        end: State,
    },
    Ended(State),
}

struct Model {
    plan: OperationPlan,
    at: At,
    /// When the step last (re)started, and its time used before that.
    since: u64,
    used: u64,
    /// When the current hold began, and the held time so far.
    held_since: u64,
    held: u64,
    /// An operator's abort was taken (until a reset).
    aborted: bool,
    /// Attempts asked for so far (a reset does not start them again).
    attempts: u32,
}

impl Model {
    fn new(plan: OperationPlan) -> Self {
        Model {
            plan,
            at: At::Idle,
            since: 0,
            used: 0,
            held_since: 0,
            held: 0,
            aborted: false,
            attempts: 0,
        }
    }

    /// A new attempt's number.
    fn attempt(&mut self) -> u32 {
        self.attempts += 1;
        self.attempts - 1
    }

    /// The latest attempt (the one in flight, if any).
    fn latest(&self) -> u32 {
        self.attempts.saturating_sub(1)
    }

    fn state(&self) -> State {
        match self.at {
            At::Idle => State::Idle,
            At::Queued => State::Queued,
            At::Withdrawing { end, .. } => match end {
                State::Stopped => State::Stopping,
                State::Aborted => State::Aborting,
                _ => State::Withdrawing,
            },
            At::Step { stopping: true, .. } => State::Stopping,
            At::Step { .. } => State::Running,
            At::Holding { .. } => State::Holding,
            At::Held { .. } => State::Held,
            At::Restarting { .. } => State::Restarting,
            At::Releasing { abort: true, .. } => State::Aborting,
            At::Releasing { stop: true, .. } => State::Stopping,
            At::Releasing { .. } => State::Completing,
            At::Faulting {
                end: State::Aborted,
            } => State::Aborting,
            At::Faulting { .. } => State::Faulting,
            At::Ended(state) => state,
        }
    }

    fn step(&self) -> Option<usize> {
        match self.at {
            At::Step { i, .. } | At::Holding { i } | At::Held { i } | At::Restarting { i } => {
                Some(i)
            }
            _ => None,
        }
    }

    fn last(&self) -> usize {
        self.plan.steps.len() - 1
    }

    fn start(&mut self, i: usize, stopping: bool, now: u64, out: &mut Vec<Expect>) {
        self.at = At::Step { i, stopping };
        self.since = now;
        let timeout = self.plan.steps[i]
            .timeout_ms()
            .saturating_sub(ms(self.used))
            .max(ms(1));
        let attempt = self.attempt();
        out.push(Expect::Start(i, timeout, attempt));
    }

    fn hold(&mut self, i: usize, out: &mut Vec<Expect>) {
        if self.plan.hold.is_some() {
            self.at = At::Holding { i };
            let attempt = self.attempt();
            out.extend([Expect::Entered(State::Holding), Expect::Hold(attempt)]);
        } else {
            self.at = At::Held { i };
            out.push(Expect::Entered(State::Held));
        }
    }

    /// Stopping from step `from`: the return to idle (unless past it), or the release.
    fn return_to_idle(&mut self, from: usize, now: u64, out: &mut Vec<Expect>) {
        self.used = 0;
        if from <= self.last() {
            self.start(self.last(), true, now, out);
        } else {
            self.at = At::Releasing {
                stop: true,
                abort: false,
            };
            out.push(Expect::Release);
        }
    }

    fn restart_done(&mut self, i: usize, now: u64, out: &mut Vec<Expect>) {
        self.held += now.saturating_sub(self.held_since);
        if self.plan.steps[i].restart() == RestartRule::Rerun {
            self.used = 0;
        }
        out.push(Expect::Entered(State::Running));
        self.start(i, false, now, out);
    }

    fn fault(&mut self, end: State, out: &mut Vec<Expect>) {
        self.at = At::Faulting { end };
        out.push(Expect::Fault);
    }

    /// A command the table allows.
    fn command(&mut self, c: Command, now: u64) -> Vec<Expect> {
        let mut out = Vec::new();
        self.aborted |= c == Command::Abort;
        match (self.at, c) {
            (At::Idle, Command::Start) => {
                self.at = At::Queued;
                out.push(Expect::Acquire);
            }
            (At::Step { i, .. }, Command::Hold) => {
                self.used += now.saturating_sub(self.since);
                self.held_since = now;
                out.push(Expect::Cancel(i, self.latest()));
                self.hold(i, &mut out);
            }
            (At::Restarting { i }, Command::Hold) => {
                out.push(Expect::Cancel(i, self.latest()));
                self.hold(i, &mut out);
            }
            (At::Held { i }, Command::Restart) => {
                self.at = At::Restarting { i };
                out.push(Expect::Entered(State::Restarting));
                // The hold sets P, which no step but the return to idle
                // commands: something to restore, unless held in that step.
                if self.plan.hold.is_some() && i != self.last() {
                    let attempt = self.attempt();
                    out.push(Expect::Restore(attempt));
                } else {
                    self.restart_done(i, now, &mut out);
                }
            }
            (At::Queued, Command::Stop) => {
                self.at = At::Withdrawing {
                    end: State::Stopped,
                    handed_back: false,
                };
                out.extend([Expect::Entered(State::Stopping), Expect::Withdraw]);
            }
            (At::Step { i, .. }, Command::Stop) => {
                if self.plan.stop == StopRule::FinishStep || i == self.last() {
                    self.at = At::Step { i, stopping: true };
                    out.push(Expect::Entered(State::Stopping));
                } else {
                    out.extend([
                        Expect::Cancel(i, self.latest()),
                        Expect::Entered(State::Stopping),
                    ]);
                    self.return_to_idle(i, now, &mut out);
                }
            }
            (At::Held { i }, Command::Stop) => {
                self.held += now.saturating_sub(self.held_since);
                out.push(Expect::Entered(State::Stopping));
                self.return_to_idle(i, now, &mut out);
            }
            (At::Queued, Command::Abort) => {
                self.at = At::Withdrawing {
                    end: State::Aborted,
                    handed_back: false,
                };
                out.extend([Expect::Entered(State::Aborting), Expect::Withdraw]);
            }
            (At::Withdrawing { handed_back, .. }, Command::Abort) => {
                self.at = At::Withdrawing {
                    end: State::Aborted,
                    handed_back,
                };
                out.push(Expect::Entered(State::Aborting));
            }
            (At::Releasing { stop: true, .. }, Command::Abort) => {
                self.at = At::Releasing {
                    stop: true,
                    abort: true,
                };
                out.push(Expect::Entered(State::Aborting));
            }
            (
                At::Step { i, .. } | At::Holding { i } | At::Held { i } | At::Restarting { i },
                Command::Abort,
            ) => {
                if matches!(self.at, At::Held { .. }) {
                    self.held += now.saturating_sub(self.held_since);
                } else {
                    out.push(Expect::Cancel(i, self.latest()));
                }
                out.push(Expect::Entered(State::Aborting));
                self.fault(State::Aborted, &mut out);
            }
            (At::Ended(_), Command::Reset) => {
                let attempts = self.attempts;
                *self = Model::new(self.plan.clone());
                self.attempts = attempts;
                out.push(Expect::Entered(State::Idle));
            }
            (at, c) => panic!("the table allows {c} in {at:?}, the model does not"),
        }
        out
    }

    fn event(&mut self, input: Input, now: u64) -> Vec<Expect> {
        let mut out = Vec::new();
        match (self.at, input) {
            (At::Queued, Input::Granted) => {
                self.used = 0;
                self.start(0, false, now, &mut out);
            }
            (At::Queued, Input::Refused) => {
                self.at = At::Ended(State::Refused);
                out.push(Expect::Failed(State::Refused));
            }
            (At::Queued, Input::Interrupt) => {
                self.at = At::Withdrawing {
                    end: State::Withdrawn,
                    handed_back: false,
                };
                out.push(Expect::Withdraw);
            }
            (
                At::Withdrawing {
                    end,
                    handed_back: false,
                },
                Input::Granted,
            ) => {
                self.at = At::Withdrawing {
                    end,
                    handed_back: true,
                };
                out.push(Expect::Release);
            }
            (
                At::Withdrawing {
                    end,
                    handed_back: false,
                },
                Input::Withdrawn,
            )
            | (
                At::Withdrawing {
                    end,
                    handed_back: true,
                },
                Input::Released,
            ) => {
                self.at = At::Ended(end);
                out.push(match end {
                    State::Stopped => Expect::Stopped,
                    end => Expect::Failed(end),
                });
            }
            (
                At::Withdrawing {
                    end,
                    handed_back: true,
                },
                Input::ReleaseFailed,
            ) => {
                let end = if end == State::Stopped {
                    State::Faulted
                } else {
                    State::Aborted
                };
                self.fault(end, &mut out);
            }
            (At::Step { i, stopping }, Input::StepDone) => {
                self.used = 0;
                if stopping {
                    self.return_to_idle(i + 1, now, &mut out);
                } else if i == self.last() {
                    self.at = At::Releasing {
                        stop: false,
                        abort: false,
                    };
                    out.push(Expect::Release);
                } else {
                    self.start(i + 1, false, now, &mut out);
                }
            }
            (At::Step { .. }, Input::StepFailed)
            | (At::Holding { .. }, Input::HoldFailed)
            | (At::Restarting { .. }, Input::RestartFailed) => {
                self.fault(State::Faulted, &mut out);
            }
            (At::Holding { i }, Input::HoldDone) => {
                self.at = At::Held { i };
                out.push(Expect::Entered(State::Held));
            }
            (At::Restarting { i }, Input::RestartDone) => self.restart_done(i, now, &mut out),
            (At::Releasing { stop: false, .. }, Input::Released) => {
                self.at = At::Ended(State::Complete);
                out.push(Expect::Finished(ms(self.held)));
            }
            (At::Releasing { stop: true, abort }, Input::Released) => {
                let end = if abort {
                    State::Aborted
                } else {
                    State::Stopped
                };
                self.at = At::Ended(end);
                out.push(if abort {
                    Expect::Failed(State::Aborted)
                } else {
                    Expect::Stopped
                });
            }
            (At::Releasing { abort, .. }, Input::ReleaseFailed) => {
                self.fault(
                    if abort {
                        State::Aborted
                    } else {
                        State::Faulted
                    },
                    &mut out,
                );
            }
            (At::Faulting { end }, Input::FaultApplied) => {
                self.at = At::Ended(end);
                out.push(Expect::Failed(end));
            }
            (
                At::Step { i, .. } | At::Holding { i } | At::Held { i } | At::Restarting { i },
                Input::Interrupt,
            ) => {
                if matches!(self.at, At::Held { .. }) {
                    self.held += now.saturating_sub(self.held_since);
                } else {
                    out.push(Expect::Cancel(i, self.latest()));
                }
                self.fault(State::Aborted, &mut out);
            }
            _ => {}
        }
        out
    }
}

/// The operation's event for an input, when it is one the tables name.
fn event_of(input: Input) -> Option<Event> {
    Some(match input {
        Input::Command(_) => return None,
        Input::Granted => Event::Granted,
        Input::Refused => Event::RequestRefused,
        Input::Withdrawn => Event::Withdrawn,
        Input::StepDone | Input::StepDoneOther => Event::StepDone,
        Input::StepFailed | Input::HoldFailed | Input::RestartFailed => Event::Failed,
        Input::HoldDone => Event::HoldDone,
        Input::RestartDone => Event::RestartDone,
        Input::Released => Event::Released,
        Input::ReleaseFailed => Event::ReleaseFailed,
        Input::FaultApplied => Event::FaultApplied,
        Input::Interrupt => Event::Interrupted,
        Input::Stale(..) => return None,
    })
}

/// Whether `to` is reached from `from` by moves events declare (none, or several in one input).
fn by_events(from: State, to: State) -> bool {
    let mut reached = vec![from];
    let mut i = 0;
    while i < reached.len() {
        let here = reached[i];
        for &(f, _, t) in OPERATION_EVENTS {
            if f == here && !reached.contains(&t) {
                reached.push(t);
            }
        }
        i += 1;
    }
    reached.contains(&to)
}

/// Effects that command the plant or the interlock.
fn commands_something(e: &Expect) -> bool {
    matches!(
        e,
        Expect::Acquire
            | Expect::Start(..)
            | Expect::Hold(_)
            | Expect::Restore(_)
            | Expect::Release
            | Expect::Withdraw
            | Expect::Fault
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2048))]

    #[test]
    fn a_run_under_commands_matches_the_reference(
        steps in prop::collection::vec((any::<bool>(), any::<bool>()), 1..=4),
        hold in any::<bool>(),
        stop_now in any::<bool>(),
        inputs in prop::collection::vec((input(), 0..3000u64), 0..60),
    ) {
        let plan = plan(&steps, hold, stop_now);
        let mut run = OperationRun::new(plan.clone());
        let mut model = Model::new(plan.clone());
        let who = Attribution::new(Some("ana"), Some("gasket"), false);
        let mut now = 0u64;
        for (input, dt) in inputs {
            now += dt;
            let before = run.state();
            prop_assert_eq!(before, model.state());
            let effects = match input {
                Input::Command(c) => match run.command(c, &who, ms(now)) {
                    Ok(effects) => {
                        let verdict = OPERATION.verdict(before, c);
                        prop_assert!(matches!(verdict, Verdict::To(_)), "{} taken in {}", c, before);
                        // The command's own move first, then only moves events declare.
                        let Verdict::To(first) = verdict else { unreachable!() };
                        prop_assert!(by_events(first, run.state()), "{} in {}: {} then {}", c, before, first, run.state());
                        let expected = model.command(c, now);
                        prop_assert_eq!(effects.iter().map(seen).collect::<Vec<_>>(), expected, "{} in {}", c, before);
                        effects
                    }
                    Err(err) => {
                        prop_assert!(matches!(OPERATION.verdict(before, c), Verdict::Refused(..)) || c == Command::Start,
                            "{} refused in {}: {}", c, before, err);
                        prop_assert_eq!(run.state(), before, "a refused command changed the state");
                        Vec::new()
                    }
                },
                Input::Stale(answer, n) => {
                    let Some(attempt) = model.latest().checked_sub(n) else { continue };
                    let effects = match answer {
                        Answer::StepDone => run.step_done(attempt, ms(now)),
                        Answer::StepFailed => run.step_failed(attempt, "COMMAND_TIMEOUT", "late", ms(now)),
                        Answer::HoldDone => run.hold_done(attempt, ms(now)),
                        Answer::HoldFailed => run.hold_failed(attempt, "COMMAND_FAILED", "stuck", ms(now)),
                        Answer::RestartDone => run.restart_done(attempt, ms(now)),
                        Answer::RestartFailed => run.restart_failed(attempt, "COMMAND_FAILED", "stuck", ms(now)),
                    };
                    prop_assert!(effects.is_empty(), "{:?} of attempt {} in {}: {:?}", answer, attempt, before, effects);
                    prop_assert_eq!(run.state(), before, "an earlier attempt's answer moved the run");
                    effects
                }
                _ => {
                    // The answers name the latest attempt: the one in flight, if any.
                    let attempt = model.latest();
                    let effects = match input {
                        Input::Granted => run.granted(ms(now)),
                        Input::Refused => run.refused("QUEUE_FULL", "the queue is full"),
                        Input::Withdrawn => run.withdrawn(ms(now)),
                        Input::StepDone => run.step_done(attempt, ms(now)),
                        Input::StepDoneOther => run.step_done(attempt + 1, ms(now)),
                        Input::StepFailed => run.step_failed(attempt, "COMMAND_TIMEOUT", "late", ms(now)),
                        Input::HoldDone => run.hold_done(attempt, ms(now)),
                        Input::HoldFailed => run.hold_failed(attempt, "COMMAND_FAILED", "stuck", ms(now)),
                        Input::RestartDone => run.restart_done(attempt, ms(now)),
                        Input::RestartFailed => run.restart_failed(attempt, "COMMAND_FAILED", "stuck", ms(now)),
                        Input::Released => run.released(ms(now)),
                        Input::ReleaseFailed => run.release_failed("NOT_HOLDING", "gone", ms(now)),
                        Input::FaultApplied => run.fault_applied(vec!["YEL".into()], ms(now)),
                        Input::Interrupt => run.interrupt("its interlock left the flows", ms(now)),
                        Input::Command(_) | Input::Stale(..) => unreachable!(),
                    };
                    let expected = match input {
                        Input::StepDoneOther => Vec::new(),
                        _ => model.event(input, now),
                    };
                    prop_assert_eq!(effects.iter().map(seen).collect::<Vec<_>>(), expected, "{:?} in {}", input, before);
                    let event = event_of(input).unwrap();
                    prop_assert!(run.state() == before || by_events(before, run.state()),
                        "{:?} ({:?}) moved {} to {}, undeclared", input, event, before, run.state());
                    effects
                }
            };
            let after = run.state();
            prop_assert_eq!(after, model.state());
            prop_assert_eq!(run.step(), model.step());
            prop_assert_eq!(run.awaits_reset(), model.aborted);
            prop_assert!(procedure::operation_move_declared(before, after) || by_events(before, after)
                || matches!(input, Input::Command(c) if matches!(OPERATION.verdict(before, c), Verdict::To(t) if by_events(t, after))));
            // A restore leaves to its step the actuators the step commands again.
            for e in &effects {
                if let RunEffect::Restore { command, .. } = e {
                    let i = run.step().expect("a restore is of a step");
                    if let PlanStep::Command { command: own, .. } | PlanStep::ReturnToIdle { command: own, .. } = &plan.steps[i] {
                        prop_assert!(command.members().all(|(_, id, _)| own.members().all(|(_, m, _)| m != id)),
                            "the restore {:?} sets what step {} commands", command, i);
                    }
                }
            }
            // A held run commands nothing while it stays held.
            if before == State::Held && after == State::Held {
                prop_assert!(effects.is_empty(), "held, yet {:?} gave {:?}", input, effects);
            }
            // Aborted is left only by a reset.
            if before == State::Aborted && after != State::Aborted {
                prop_assert!(matches!(input, Input::Command(Command::Reset)), "{:?} left aborted", input);
            }
            if after == State::Held {
                prop_assert!(!effects.iter().map(seen).skip_while(|e| *e != Expect::Entered(State::Held)).any(|e| commands_something(&e)));
            }
            prop_assert_eq!(run.commands(), OPERATION.commands(after));
        }
    }
}

/// What a routine's pending operation is doing, in the routine model.
#[derive(Clone, Copy, Debug)]
enum RoutineInput {
    Command(Command),
    Trigger,
    OperationIs(State),
    Completed,
    NotRun,
    OperationStopped,
    OperationAborted,
    OperationFaulted,
}

fn routine_input() -> impl Strategy<Value = RoutineInput> {
    prop_oneof![
        4 => prop::sample::select(Command::OPERATOR.to_vec()).prop_map(RoutineInput::Command),
        3 => Just(RoutineInput::Trigger),
        3 => prop::sample::select(vec![State::Queued, State::Running, State::Holding, State::Held, State::Restarting]).prop_map(RoutineInput::OperationIs),
        2 => Just(RoutineInput::Completed),
        1 => Just(RoutineInput::NotRun),
        1 => Just(RoutineInput::OperationStopped),
        1 => Just(RoutineInput::OperationAborted),
        1 => Just(RoutineInput::OperationFaulted),
    ]
}

fn routine_plant(error_state: bool) -> sugarshack_core::plant::Plant {
    let op = |id: &str| {
        json!({ "id": id, "priority": 1, "resources": ["YEL"], "steps": [
        { "wait": "`LT-3` >= 0", "sensors": ["LT-3"], "timeoutMs": 1000 } ] })
    };
    let mut routine = json!({ "id": "truck", "states": ["empty", "full", "fault"], "initial": "empty",
        "transitions": [
            { "from": "empty", "to": "full", "operation": "10", "trigger": { "msg": "go" } },
            { "from": "full", "to": "empty", "operation": "12", "trigger": { "msg": "go" } },
            { "from": "fault", "to": "empty", "operation": "15", "trigger": { "msg": "go" } }
        ] });
    if error_state {
        routine["errorState"] = json!("fault");
    }
    let doc = json!({
        "actuatorTypes": {},
        "devices": [{ "id": "st", "kind": "sensor-station" }],
        "sensors": [{ "id": "LT-3", "device": "st", "name": "volume" }],
        "resources": [{ "id": "YEL", "lockout": { "valves": {} } }],
        "operations": [op("10"), op("12"), op("15")],
        "routines": [routine]
    });
    sugarshack_core::plant::Plant::new(serde_json::from_value(doc).unwrap()).unwrap()
}

/// Whether a routine moves from `from` to `to` by moves its events declare.
fn routine_by_events(from: State, to: State) -> bool {
    let mut reached = vec![from];
    let mut i = 0;
    while i < reached.len() {
        let here = reached[i];
        for &(f, _, t) in ROUTINE_EVENTS {
            if f == here && !reached.contains(&t) {
                reached.push(t);
            }
        }
        i += 1;
    }
    reached.contains(&to)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// A routine under commands and its operation's fate: every move declared,
    /// a refused command changes nothing, a held, stopped or aborted routine
    /// fires no trigger, aborted is left only by a reset, and its reset
    /// resets exactly its operations that were aborted (another's stays).
    #[test]
    fn a_routine_under_commands_moves_only_as_declared(
        error_state in any::<bool>(),
        inputs in prop::collection::vec(routine_input(), 0..50),
    ) {
        use sugarshack_core::operation::AbortedOperations;
        use sugarshack_core::routine::RoutineMachine;
        let plant = routine_plant(error_state);
        let mut r = RoutineMachine::new(&plant, "truck").unwrap();
        // The pending operation's state, as its run would say.
        let mut op: Option<State> = None;
        // The interlock's aborted operations; "99" is no operation of the routine.
        let who = Attribution::new(Some("ana"), None, false);
        let mut aborted = AbortedOperations::default();
        aborted.ended("99", State::Aborted, &who, ms(0));
        let mut model_aborted: Vec<String> = Vec::new();
        for input in inputs {
            let before = r.run_state(op);
            let before_snapshot = r.snapshot();
            match input {
                RoutineInput::Command(c) => match r.command(c, op) {
                    Ok((forward, moved)) => {
                        if moved.is_some() {
                            let mut expected: Vec<String> = r.operations().into_iter().map(String::from).filter(|o| model_aborted.contains(o)).collect();
                            let mut reset = aborted.reset_routine(&r.operations());
                            reset.sort();
                            expected.sort();
                            prop_assert_eq!(reset, expected, "a routine's reset");
                            model_aborted.clear();
                            prop_assert!(r.operations().iter().all(|o| aborted.state(o) == State::Idle));
                            prop_assert_eq!(aborted.state("99"), State::Aborted, "another's abort stands");
                        }
                        let Verdict::To(first) = procedure::ROUTINE.verdict(before, c) else {
                            panic!("{c} taken in {before}");
                        };
                        if let (Some(f), Some(state)) = (forward, op) {
                            let Verdict::To(next) = OPERATION.verdict(state, f) else {
                                panic!("{f} forwarded to an operation {state}");
                            };
                            op = Some(next);
                        }
                        let after = r.run_state(op);
                        prop_assert!(after == first || routine_by_events(first, after),
                            "{} in {}: {} then {}", c, before, first, after);
                    }
                    Err(_) => prop_assert_eq!(r.snapshot(), before_snapshot, "a refused {} changed the routine", c),
                },
                RoutineInput::Trigger => {
                    let fired = r.on_msg("go").is_ok();
                    let may = matches!(before, State::Idle | State::Running) && op.is_none();
                    prop_assert_eq!(fired, may, "a trigger in {} {}", before, if fired { "fired" } else { "was refused" });
                    if fired {
                        op = Some(State::Queued);
                    }
                }
                RoutineInput::OperationIs(state) => {
                    if op.is_some() {
                        op = Some(state);
                    }
                }
                end => {
                    // Only the ends its operation's state can come to.
                    let can_end = match (op, end) {
                        (None, _) => false,
                        (Some(State::Queued), e) => matches!(e, RoutineInput::NotRun | RoutineInput::OperationStopped | RoutineInput::OperationAborted),
                        (Some(State::Running), e) => !matches!(e, RoutineInput::NotRun | RoutineInput::OperationStopped),
                        (Some(State::Held), e) => matches!(e, RoutineInput::OperationStopped | RoutineInput::OperationAborted),
                        (Some(State::Stopping), e) => !matches!(e, RoutineInput::NotRun | RoutineInput::Completed),
                        (Some(_), e) => matches!(e, RoutineInput::OperationFaulted | RoutineInput::OperationAborted),
                    };
                    if !can_end {
                        continue;
                    }
                    if matches!(end, RoutineInput::OperationAborted) {
                        let pending = r.pending().unwrap().to_owned();
                        aborted.ended(&pending, State::Aborted, &who, ms(1));
                        if !model_aborted.contains(&pending) {
                            model_aborted.push(pending);
                        }
                    }
                    let (result, event) = match end {
                        RoutineInput::Completed => (r.completed().map(|_| ()), RoutineEvent::Completed),
                        RoutineInput::NotRun => (r.refused(), RoutineEvent::NotRun),
                        RoutineInput::OperationStopped => (r.operation_stopped().map(|_| ()), RoutineEvent::OperationStopped),
                        RoutineInput::OperationAborted => (r.operation_aborted().map(|_| ()), RoutineEvent::OperationAborted),
                        _ => (r.faulted().map(|_| ()), RoutineEvent::OperationFaulted),
                    };
                    prop_assert!(result.is_ok());
                    op = None;
                    let after = r.run_state(op);
                    prop_assert!(after == before || ROUTINE_EVENTS.iter().any(|&(f, e, t)| f == before && e == event && t == after),
                        "{:?} moved the routine {} to {}, undeclared", event, before, after);
                }
            }
            let after = r.run_state(op);
            if before == State::Aborted && after != State::Aborted {
                prop_assert!(matches!(input, RoutineInput::Command(Command::Reset)), "{:?} left aborted", input);
            }
            prop_assert_eq!(
                r.commands(op),
                procedure::ROUTINE.commands(after).into_iter().filter(|&c| {
                    let mut probe = r.clone();
                    probe.command(c, op).is_ok()
                }).collect::<Vec<_>>()
            );
        }
    }
}
