//! Step-response metrics as the paper defines them (§7.3): overshoot, steady-state
//! error, settling time within a band, pure settling time; plus the distance
//! between two responses, which is how Fig. 11 compares runs.

/// A signal sampled at increasing times (s).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trace {
    pub times_s: Vec<f64>,
    pub values: Vec<f64>,
}

impl Trace {
    pub fn push(&mut self, time_s: f64, value: f64) {
        self.times_s.push(time_s);
        self.values.push(value);
    }

    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The last sample at or before `time_s` (the value held then).
    pub fn at(&self, time_s: f64) -> Option<f64> {
        let index = self.times_s.partition_point(|&t| t <= time_s);
        index.checked_sub(1).map(|i| self.values[i])
    }

    /// (time, value) pairs with `from_s <= time <= to_s`.
    pub fn window(&self, from_s: f64, to_s: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
        let start = self.times_s.partition_point(|&t| t < from_s);
        let end = self.times_s.partition_point(|&t| t <= to_s);
        (start..end).map(|i| (self.times_s[i], self.values[i]))
    }

    pub fn points(&self) -> Vec<(f64, f64)> {
        self.window(f64::NEG_INFINITY, f64::INFINITY).collect()
    }

    pub fn end_s(&self) -> f64 {
        self.times_s.last().copied().unwrap_or(0.0)
    }

    /// Largest minus smallest value in the window (0 for an empty window).
    pub fn peak_to_peak(&self, from_s: f64, to_s: f64) -> f64 {
        let (low, high) = self
            .window(from_s, to_s)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (_, v)| {
                (lo.min(v), hi.max(v))
            });
        if high >= low {
            high - low
        } else {
            0.0
        }
    }

    pub fn mean(&self, from_s: f64, to_s: f64) -> f64 {
        let (sum, count) = self
            .window(from_s, to_s)
            .fold((0.0, 0usize), |(s, n), (_, v)| (s + v, n + 1));
        sum / count as f64
    }
}

/// The paper's settling band: within 5 % of the final value (§7.3).
pub const SETTLING_BAND: f64 = 0.05;

/// A step from `initial` to `setpoint` applied at `step_at_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    pub at_s: f64,
    pub initial: f64,
    pub setpoint: f64,
}

impl Step {
    pub fn size(&self) -> f64 {
        self.setpoint - self.initial
    }

    /// Half-width of the settling band: a share of the step size, so a step from
    /// 0.69 to 1.04 is judged on the 0.35 it moves, not on the 1.04 it ends at.
    pub fn band(&self) -> f64 {
        SETTLING_BAND * self.size().abs()
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepMetrics {
    /// Mean of the last `tail_s` of the run.
    pub final_value: f64,
    /// M_p: peak beyond the final value, in % of the step the output made.
    pub overshoot_pct: f64,
    /// e_ss: set point minus final value.
    pub steady_state_error: f64,
    /// t_s from the step; `None` when the output never stays in the band
    /// (it is still moving or oscillating when the run ends).
    pub settling_time_s: Option<f64>,
}

impl StepMetrics {
    /// t_ps = t_s - D_c (the paper's pure settling time), for a compensator set to `dead_time_s`.
    pub fn pure_settling_time_s(&self, dead_time_s: f64) -> Option<f64> {
        self.settling_time_s.map(|t| t - dead_time_s)
    }
}

pub fn step_metrics(trace: &Trace, step: Step, tail_s: f64) -> StepMetrics {
    let end = trace.end_s();
    let final_value = trace.mean(end - tail_s, end);
    StepMetrics {
        final_value,
        overshoot_pct: overshoot_pct(trace, step, final_value),
        steady_state_error: step.setpoint - final_value,
        settling_time_s: settling_time_s(trace, step, final_value, step.band(), tail_s),
    }
}

/// Peak past `final_value` in the direction of the step, in % of the change made (0 if none).
pub fn overshoot_pct(trace: &Trace, step: Step, final_value: f64) -> f64 {
    let direction = step.size().signum();
    let change = (final_value - step.initial).abs();
    if change == 0.0 {
        return 0.0;
    }
    let peak = trace
        .window(step.at_s, f64::INFINITY)
        .map(|(_, v)| direction * (v - final_value))
        .fold(0.0, f64::max);
    100.0 * peak / change
}

/// Time from the step to the last entry into `final_value ± band`; `None` if the
/// output is outside the band anywhere in the last `tail_s` of the run.
pub fn settling_time_s(
    trace: &Trace,
    step: Step,
    final_value: f64,
    band: f64,
    tail_s: f64,
) -> Option<f64> {
    let outside = |v: f64| (v - final_value).abs() > band;
    let after: Vec<(f64, f64)> = trace.window(step.at_s, f64::INFINITY).collect();
    let last_out = after.iter().rposition(|&(_, v)| outside(v));
    match last_out {
        None => Some(0.0),
        Some(i) if i + 1 == after.len() || after[i].0 >= trace.end_s() - tail_s => None,
        Some(i) => Some(after[i + 1].0 - step.at_s),
    }
}

/// Largest |a - b| over the window, comparing each sample of `a` with `b`'s value then.
pub fn max_difference(a: &Trace, b: &Trace, from_s: f64, to_s: f64) -> f64 {
    a.window(from_s, to_s)
        .filter_map(|(t, va)| b.at(t).map(|vb| (va - vb).abs()))
        .fold(0.0, f64::max)
}

/// A response that neither settles nor creeps: over the last quarter of the
/// run it swings by more than twice the settling band's width and crosses its
/// own mean there, both ways, at least once (a creep crosses it once at most).
pub fn oscillates(trace: &Trace, step: Step, metrics: &StepMetrics) -> bool {
    let end = trace.end_s();
    let from = end - (end - step.at_s) / 4.0;
    let swing = trace.peak_to_peak(from, end);
    metrics.settling_time_s.is_none()
        && swing > 2.0 * (2.0 * step.band())
        && mean_crossings(trace, from, end, step.band()) >= 2
}

/// How many times the signal passes from one side of its window mean to the
/// other, counting only excursions beyond `hysteresis` so noise does not count.
fn mean_crossings(trace: &Trace, from_s: f64, to_s: f64, hysteresis: f64) -> usize {
    let mean = trace.mean(from_s, to_s);
    let mut side = 0i8;
    let mut crossings = 0;
    for (_, v) in trace.window(from_s, to_s) {
        let now = if v > mean + hysteresis {
            1
        } else if v < mean - hysteresis {
            -1
        } else {
            continue;
        };
        if side != 0 && now != side {
            crossings += 1;
        }
        side = now;
    }
    crossings
}

/// Peak-to-peak swing of the last quarter over that of the second quarter after
/// the step: above 1 the oscillation grows, below 1 it dies out.
pub fn swing_growth(trace: &Trace, step: Step) -> f64 {
    let end = trace.end_s();
    let quarter = (end - step.at_s) / 4.0;
    let early = trace.peak_to_peak(step.at_s + quarter, step.at_s + 2.0 * quarter);
    let late = trace.peak_to_peak(end - quarter, end);
    if early == 0.0 {
        if late == 0.0 {
            0.0
        } else {
            f64::INFINITY
        }
    } else {
        late / early
    }
}
