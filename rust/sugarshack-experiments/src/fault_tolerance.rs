//! The paper's §7.2 (Table 2, Fig. 11): a flow loop run by two remote
//! controllers under RCC; the primary's link fails at 22 s and comes back at
//! 78 s. Each controller polls the I/O module on its own schedule over its own
//! connection; who acts is decided only from the ages the I/O module counts.

use std::collections::VecDeque;

use crate::sim::{DelayDist, Failure, FailureSchedule, FirstOrderParams, FirstOrderProcess, Link};
use sugarshack_core::control::error::time;
use sugarshack_core::control::pid::{Action, Pid, PidConfig};
use sugarshack_core::control::rcc::{
    thresholds_from_ms, IoModule, IoState, RccConfig, RccController,
};
use sugarshack_core::control::ControlError;

use crate::metrics::{max_difference, step_metrics, Step, StepMetrics, Trace};
use crate::tuning::{apparent_dead_time_s, gain_for_crossover, ziegler_nichols_pi, PiTuning};

/// Table 2: Ts = 200 ms.
pub const TS_MS: i64 = 200;
/// Simulation step: 1/20 of Ts, fine enough for 100 ms network legs.
pub const TICK_MS: i64 = 10;
/// Table 2 gives τ = 2 s only; the gain is taken as 1 (the action is the flow
/// the valve is asked for, in gal/min) and the process itself has no dead time.
pub const FLOW_PROCESS: FirstOrderParams = FirstOrderParams {
    gain: 1.0,
    tau_s: 2.0,
    dead_time_s: 0.0,
};
/// Table 2's 200 ms average round trip, split evenly between the two directions.
pub const ONE_WAY_DELAY_MS: f64 = 100.0;
pub const ROUND_TRIP_MS: f64 = 2.0 * ONE_WAY_DELAY_MS;
/// A poll unanswered after this long has timed out (Fig. 7 line 10): five round
/// trips, so only a broken link trips it, never an ordinary late reply.
pub const POLL_TIMEOUT_MS: i64 = 1000;
pub const PRIMARY: usize = 1;
pub const BACKUP: usize = 2;
/// D_1 = Ts, the least RCC allows; D_2 = 2·Ts: the primary's writes come every
/// Ts, so its age never reaches 2·Ts while it is alive, and the backup waits
/// no longer than it must.
pub const ENGAGEMENT_THRESHOLDS_MS: [f64; 2] = [TS_MS as f64, 2.0 * TS_MS as f64];
/// A valve sized for about twice the nominal flow.
pub const ACTION_LIMITS: (f64, f64) = (0.0, 2.0);
/// Table 2's set point 0.69 + 0.35·u(t - 5) gal/min.
pub const SET_POINT_STEP: Step = Step {
    at_s: 5.0,
    initial: 0.69,
    setpoint: 1.04,
};
/// Table 2: the primary fails at 22 s and recovers at 78 s.
pub const FAIL_AT_S: f64 = 22.0;
pub const RECOVER_AT_S: f64 = 78.0;
pub const DURATION_S: f64 = 100.0;
/// The backup is started 10 s after the primary (redundant controllers do not
/// start together, §5.3), 70 ms out of phase with it (no shared clock).
pub const BACKUP_START_MS: i64 = 10_070;
pub const PRIMARY_PHASE_MS: i64 = 0;

/// The dead time the controller sees: the round trip plus half a sample of hold.
pub fn apparent_dead_time() -> f64 {
    apparent_dead_time_s(
        ROUND_TRIP_MS / 1000.0,
        TS_MS as f64 / 1000.0,
        FLOW_PROCESS.dead_time_s,
    )
}

/// Ziegler-Nichols' reaction-curve PI for the loop the controller sees.
pub fn ziegler_nichols() -> PiTuning {
    ziegler_nichols_pi(FLOW_PROCESS.gain, FLOW_PROCESS.tau_s, apparent_dead_time())
}

/// ZN aims at a quarter-amplitude decay; the paper then fine-tuned its loops.
/// Its 22 s failure fell inside the transient of the 5 s step, so its loop
/// took well over 17 s to settle. We keep ZN's integral time and set the gain
/// for a crossover of 0.1 rad/s: a closed-loop time constant of about 10 s,
/// hence 5 % settling about 30 s after the step, like the paper's.
pub const TARGET_CROSSOVER_RAD_S: f64 = 0.1;

pub fn tuning() -> PiTuning {
    let zn = ziegler_nichols();
    PiTuning {
        kp: gain_for_crossover(
            FLOW_PROCESS.gain,
            FLOW_PROCESS.tau_s,
            zn.ti_s,
            TARGET_CROSSOVER_RAD_S,
        ),
        ti_s: zn.ti_s,
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Redundancy {
    /// The primary alone: nothing acts while it is cut off.
    PrimaryOnly,
    /// Primary and backup under RCC.
    Rcc { smooth_handover: bool },
}

#[derive(Clone, Debug, PartialEq)]
pub struct FaultScenario {
    pub redundancy: Redundancy,
    /// Failures and recoveries (time in s). A crashed controller loses its
    /// state and restarts fresh; a cut link loses what is in flight.
    pub failures: Vec<(f64, Failure)>,
    pub tuning: PiTuning,
    pub backup_start_ms: i64,
    pub duration_s: f64,
}

impl FaultScenario {
    /// Table 2's run with or without the primary's 22-78 s outage.
    pub fn paper(redundancy: Redundancy, failure: bool) -> Self {
        Self {
            redundancy,
            failures: if failure {
                vec![
                    (FAIL_AT_S, Failure::LinkDown(PRIMARY)),
                    (RECOVER_AT_S, Failure::LinkUp(PRIMARY)),
                ]
            } else {
                Vec::new()
            },
            tuning: tuning(),
            backup_start_ms: BACKUP_START_MS,
            duration_s: DURATION_S,
        }
    }
}

/// The writer of the applied action changed at `at_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Handover {
    pub at_s: f64,
    pub from: usize,
    pub to: usize,
}

#[derive(Clone, Debug, Default)]
pub struct FaultRun {
    /// Flow (gal/min), every tick.
    pub output: Trace,
    /// The action the actuator holds, every tick.
    pub action: Trace,
    pub handovers: Vec<Handover>,
}

/// The final value is the mean flow over the run's last 5τ.
pub const FINAL_VALUE_TAIL_S: f64 = 5.0 * FLOW_PROCESS.tau_s;

impl FaultRun {
    pub fn metrics(&self) -> StepMetrics {
        step_metrics(&self.output, SET_POINT_STEP, FINAL_VALUE_TAIL_S)
    }
}

pub fn set_point(t_s: f64) -> f64 {
    if t_s >= SET_POINT_STEP.at_s {
        SET_POINT_STEP.setpoint
    } else {
        SET_POINT_STEP.initial
    }
}

enum ToIo {
    Poll { sent_ms: i64 },
    Write { action: f64 },
}

struct Reply {
    poll_sent_ms: i64,
    measurement: f64,
    state: IoState,
}

/// One remote controller: its RCC layer, its PID, and its own connection.
struct Remote {
    id: usize,
    rcc: RccController,
    pid: Pid,
    alive: bool,
    phase_ms: i64,
    start_ms: i64,
    to_io: Link<ToIo>,
    to_controller: Link<Reply>,
    /// Send times of polls not yet answered, oldest first.
    outstanding: VecDeque<i64>,
}

impl Remote {
    fn new(
        id: usize,
        controllers: usize,
        scenario: &FaultScenario,
        start_ms: i64,
        phase_ms: i64,
    ) -> Result<Self, ControlError> {
        let (rcc, pid) = Self::fresh_state(id, controllers, scenario)?;
        let one_way = DelayDist::constant(ONE_WAY_DELAY_MS)?;
        Ok(Self {
            id,
            rcc,
            pid,
            alive: true,
            phase_ms,
            start_ms,
            to_io: Link::new(one_way, 2 * id as u64),
            to_controller: Link::new(one_way, 2 * id as u64 + 1),
            outstanding: VecDeque::new(),
        })
    }

    /// The RCC layer and PID of a controller just started: first cycle pending, integrator at 0.
    fn fresh_state(
        id: usize,
        controllers: usize,
        scenario: &FaultScenario,
    ) -> Result<(RccController, Pid), ControlError> {
        let (out_min, out_max) = ACTION_LIMITS;
        let pid = Pid::new(PidConfig {
            kp: scenario.tuning.kp,
            ti_s: scenario.tuning.ti_s,
            td_s: 0.0,
            out_min,
            out_max,
            action: Action::Reverse,
            fallback: None,
            proportional_on: Default::default(),
        })?;
        let smooth_handover = match scenario.redundancy {
            Redundancy::Rcc { smooth_handover } => smooth_handover,
            Redundancy::PrimaryOnly => true,
        };
        let (thresholds, ts) =
            thresholds_from_ms(&ENGAGEMENT_THRESHOLDS_MS[..controllers], TS_MS as f64)?;
        let rcc = RccController::new(RccConfig {
            id,
            thresholds,
            ts,
            smooth_handover,
            poll_timeout: None,
        })?;
        Ok((rcc, pid))
    }

    fn apply(
        &mut self,
        event: Failure,
        controllers: usize,
        scenario: &FaultScenario,
    ) -> Result<(), ControlError> {
        match event {
            Failure::LinkDown(_) | Failure::LinkUp(_) => {
                let up = matches!(event, Failure::LinkUp(_));
                self.to_io.set_up(up);
                self.to_controller.set_up(up);
            }
            Failure::ControllerDown(_) => {
                self.alive = false;
                self.outstanding.clear();
            }
            Failure::ControllerUp(_) => {
                (self.rcc, self.pid) = Self::fresh_state(self.id, controllers, scenario)?;
                self.alive = true;
            }
        }
        Ok(())
    }
}

pub fn simulate(scenario: &FaultScenario) -> Result<FaultRun, ControlError> {
    let controllers = match scenario.redundancy {
        Redundancy::PrimaryOnly => 1,
        Redundancy::Rcc { .. } => 2,
    };
    let steady_action = SET_POINT_STEP.initial / FLOW_PROCESS.gain;
    let mut process = FirstOrderProcess::new(FLOW_PROCESS, SET_POINT_STEP.initial)?;
    let mut io = IoModule::new(controllers, steady_action)?;
    let mut remotes = vec![Remote::new(
        PRIMARY,
        controllers,
        scenario,
        0,
        PRIMARY_PHASE_MS,
    )?];
    // The plant has been running at rest under the primary before t = 0.
    remotes[0].pid.set_integral(steady_action)?;
    if controllers == 2 {
        remotes.push(Remote::new(
            BACKUP,
            controllers,
            scenario,
            scenario.backup_start_ms,
            scenario.backup_start_ms % TS_MS,
        )?);
    }
    let mut schedule = FailureSchedule::new(
        scenario
            .failures
            .iter()
            .map(|&(at_s, event)| (at_s * 1000.0, event))
            .collect(),
    )?;

    let mut run = FaultRun::default();
    let mut last_writer: Option<usize> = None;
    let end_ms = (scenario.duration_s * 1000.0).round() as i64;
    let ts_s = TS_MS as f64 / 1000.0;
    for now in (0..=end_ms).step_by(TICK_MS as usize) {
        let now_f = now as f64;
        let t_s = now_f / 1000.0;
        for event in schedule.due(now_f) {
            let (Failure::LinkDown(id)
            | Failure::LinkUp(id)
            | Failure::ControllerDown(id)
            | Failure::ControllerUp(id)) = event;
            let remote = id
                .checked_sub(1)
                .and_then(|index| remotes.get_mut(index))
                .ok_or(ControlError::UnknownController { id, controllers })?;
            remote.apply(event, controllers, scenario)?;
        }

        // The I/O module answers polls and applies writes as they arrive.
        for remote in &mut remotes {
            for message in remote.to_io.receive(now_f) {
                match message {
                    ToIo::Poll { sent_ms } => {
                        let reply = Reply {
                            poll_sent_ms: sent_ms,
                            measurement: process.output(),
                            state: io.state(time(now_f, "time (ms)")?),
                        };
                        remote.to_controller.send(reply, now_f);
                    }
                    ToIo::Write { action } => {
                        io.write(remote.id, action, time(now_f, "time (ms)")?)?;
                        if let Some(from) = last_writer.filter(|&w| w != remote.id) {
                            run.handovers.push(Handover {
                                at_s: t_s,
                                from,
                                to: remote.id,
                            });
                        }
                        last_writer = Some(remote.id);
                    }
                }
            }
        }

        // Each controller on its own schedule: poll, and scan each reply.
        for remote in &mut remotes {
            if now < remote.start_ms || !remote.alive {
                remote.to_controller.receive(now_f); // a host that is down reads nothing
                continue;
            }
            while remote
                .outstanding
                .front()
                .is_some_and(|&sent| now - sent >= POLL_TIMEOUT_MS)
            {
                remote.outstanding.pop_front();
                remote.rcc.poll_timed_out();
            }
            if (now - remote.phase_ms) % TS_MS == 0 {
                // Sent even when the link is down: the poll is lost and times out.
                remote.to_io.send(ToIo::Poll { sent_ms: now }, now_f);
                remote.outstanding.push_back(now);
            }
            for reply in remote.to_controller.receive(now_f) {
                let Some(position) = remote
                    .outstanding
                    .iter()
                    .position(|&sent| sent == reply.poll_sent_ms)
                else {
                    continue; // answered after its timeout: already given up on
                };
                if position > 0 {
                    // Replies come in order: the polls before this one are lost, i.e. timed out.
                    remote.rcc.poll_timed_out();
                }
                remote.outstanding.drain(..=position);
                let scan = remote.rcc.scan(
                    &mut remote.pid,
                    &reply.state,
                    set_point(t_s),
                    Some(reply.measurement),
                    ts_s,
                )?;
                if let Some(action) = scan.write {
                    remote.to_io.send(ToIo::Write { action }, now_f);
                }
            }
        }

        run.output.push(t_s, process.output());
        run.action.push(t_s, io.last_action());
        process.step(io.last_action(), 0.0, TICK_MS as f64 / 1000.0)?;
    }
    Ok(run)
}

/// Theorem 3's bound on the settling time added by one failure, in seconds:
/// (ceil((RTT_j + D_j) / Ts) - 2) samples.
pub fn theorem3_bound_s(round_trip_ms: f64, threshold_ms: f64, ts_ms: f64) -> f64 {
    let samples = ((round_trip_ms + threshold_ms) / ts_ms).ceil() - 2.0;
    samples.max(0.0) * ts_ms / 1000.0
}

/// The four runs of Fig. 11.
#[derive(Clone, Debug)]
pub struct Figure11 {
    pub no_failure: FaultRun,
    pub rcc: FaultRun,
    pub rcc_no_smooth_handover: FaultRun,
    pub no_redundancy: FaultRun,
}

pub fn figure11() -> Result<Figure11, ControlError> {
    Ok(Figure11 {
        no_failure: simulate(&FaultScenario::paper(
            Redundancy::Rcc {
                smooth_handover: true,
            },
            false,
        ))?,
        rcc: simulate(&FaultScenario::paper(
            Redundancy::Rcc {
                smooth_handover: true,
            },
            true,
        ))?,
        rcc_no_smooth_handover: simulate(&FaultScenario::paper(
            Redundancy::Rcc {
                smooth_handover: false,
            },
            true,
        ))?,
        no_redundancy: simulate(&FaultScenario::paper(Redundancy::PrimaryOnly, true))?,
    })
}

/// Handovers this close together are one event: after a recovery, writes both
/// controllers had in flight still land for about a round trip plus a sample.
pub const HANDOVER_EVENT_GAP_S: f64 = 1.0;
/// After the actuator freezes, the flow needs about 4τ to reach what the last
/// action gives (within e^-4 ≈ 2 % of the remaining gap); from then on it is flat.
pub const STALL_SETTLE_S: f64 = 4.0 * FLOW_PROCESS.tau_s;
/// Failure instants for the Theorem 3 sweep are this far apart: not a multiple
/// of Ts, so they fall at every phase of both controllers' schedules.
pub const SWEEP_STEP_S: f64 = 0.25;

/// Start times of handover events (handovers grouped by `HANDOVER_EVENT_GAP_S`).
pub fn handover_events(run: &FaultRun) -> Vec<f64> {
    let mut events: Vec<f64> = Vec::new();
    let mut last: Option<f64> = None;
    for h in &run.handovers {
        if last.is_none_or(|l| h.at_s - l > HANDOVER_EVENT_GAP_S) {
            events.push(h.at_s);
        }
        last = Some(h.at_s);
    }
    events
}

/// For each handover event: the largest distance from `reference` until the next event.
pub fn event_bumps(run: &FaultRun, reference: &FaultRun) -> Vec<(f64, f64)> {
    let events = handover_events(run);
    events
        .iter()
        .enumerate()
        .map(|(i, &at)| {
            let until = events.get(i + 1).copied().unwrap_or(f64::INFINITY);
            (
                at,
                max_difference(&run.output, &reference.output, at, until),
            )
        })
        .collect()
}

/// The output while nothing acts (primary cut off, no backup).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stall {
    /// Mean flow over the flat stretch.
    pub level: f64,
    /// Largest minus smallest flow over it.
    pub swing: f64,
    /// The set point then.
    pub setpoint: f64,
    pub from_s: f64,
    pub to_s: f64,
}

pub fn stall(run: &FaultRun) -> Stall {
    let (from_s, to_s) = (FAIL_AT_S + STALL_SETTLE_S, RECOVER_AT_S);
    Stall {
        level: run.output.mean(from_s, to_s),
        swing: run.output.peak_to_peak(from_s, to_s),
        setpoint: set_point(from_s),
        from_s,
        to_s,
    }
}

/// Theorem 3's bound against the settling time one failure added.
#[derive(Clone, Debug, PartialEq)]
pub struct Theorem3 {
    /// The bound as the paper states it: (ceil((RTT_j + D_j)/Ts) - 2) samples.
    pub bound_s: f64,
    /// The longest the actuator can go without a new action beyond its usual
    /// Ts: the backup sees the primary's age reach D_j at its next poll (up to
    /// Ts late), and its action needs a round trip to land; minus the usual Ts
    /// that leaves D_j + RTT_j, i.e. ceil((RTT_j + D_j)/Ts) samples. A loop slow
    /// next to that gap is simply set back by it.
    pub gap_bound_s: f64,
    pub no_failure_settling_s: f64,
    /// Added settling time with the paper's failure at 22 s.
    pub added_at_paper_failure_s: f64,
    /// (failure instant, added settling time) for failures across the transient.
    pub sweep: Vec<(f64, f64)>,
}

impl Theorem3 {
    /// The failure that added the most settling time, and how much.
    pub fn worst(&self) -> (f64, f64) {
        self.sweep
            .iter()
            .copied()
            .fold(
                (f64::NAN, f64::NEG_INFINITY),
                |w, p| if p.1 > w.1 { p } else { w },
            )
    }
}

/// Settling time; infinite if the flow never settles within the run.
fn settling_s(run: &FaultRun) -> f64 {
    run.metrics().settling_time_s.unwrap_or(f64::INFINITY)
}

/// The added settling time at the paper's failure, and for failures every
/// `SWEEP_STEP_S` from one second after the backup started (the theorem needs
/// a backup to hand over to) until the no-failure run settles.
pub fn theorem3(figure: &Figure11) -> Result<Theorem3, ControlError> {
    let base = settling_s(&figure.no_failure);
    let added_at_paper_failure_s = settling_s(&figure.rcc) - base;
    let settled_at = SET_POINT_STEP.at_s + base;
    let mut sweep = Vec::new();
    let mut fail_at = BACKUP_START_MS as f64 / 1000.0 + 1.0;
    while fail_at < settled_at {
        // One failure, no recovery within the run.
        let scenario = FaultScenario {
            failures: vec![(fail_at, Failure::LinkDown(PRIMARY))],
            ..FaultScenario::paper(
                Redundancy::Rcc {
                    smooth_handover: true,
                },
                true,
            )
        };
        sweep.push((fail_at, settling_s(&simulate(&scenario)?) - base));
        fail_at += SWEEP_STEP_S;
    }
    let (rtt, threshold, ts) = (
        ROUND_TRIP_MS,
        ENGAGEMENT_THRESHOLDS_MS[BACKUP - 1],
        TS_MS as f64,
    );
    Ok(Theorem3 {
        bound_s: theorem3_bound_s(rtt, threshold, ts),
        gap_bound_s: ((rtt + threshold) / ts).ceil() * ts / 1000.0,
        no_failure_settling_s: base,
        added_at_paper_failure_s,
        sweep,
    })
}
