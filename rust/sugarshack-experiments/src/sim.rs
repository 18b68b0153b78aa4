//! A deterministic plant and network for trying controllers offline: a seeded
//! random source, the delay shapes of the paper's §7.3, a first-order process
//! with dead time, a one-way network link with TCP's in-order delivery, and a
//! schedule of failures. Time is always an argument; the same seed gives the
//! same run on every machine.

use std::collections::VecDeque;

use sugarshack_core::control::error::{finite, positive, ControlError};
use sugarshack_core::text::quote;

/// xoshiro256** seeded through splitmix64: fast, small, and reproducible
/// everywhere, which is all a simulator needs (not for cryptography).
#[derive(Clone, Debug)]
pub struct Rng {
    state: [u64; 4],
    spare_normal: Option<f64>,
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        let mut s = seed;
        let mut next = || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        Self {
            state: [next(), next(), next(), next()],
            spare_normal: None,
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        let [s0, s1, s2, s3] = &mut self.state;
        let result = s1.wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = *s1 << 17;
        *s2 ^= *s0;
        *s3 ^= *s1;
        *s1 ^= *s2;
        *s0 ^= *s3;
        *s2 ^= t;
        *s3 = s3.rotate_left(45);
        result
    }

    /// Uniform in [0, 1), on the 2^-53 grid.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Standard normal (Box-Muller; the second value of each pair is kept for the next call).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare_normal.take() {
            return z;
        }
        // 1 - u is in (0, 1], so the logarithm is finite.
        let radius = (-2.0 * (1.0 - self.uniform()).ln()).sqrt();
        let angle = std::f64::consts::TAU * self.uniform();
        self.spare_normal = Some(radius * angle.sin());
        radius * angle.cos()
    }
}

/// How long one packet takes, in ms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DelayDist {
    Constant {
        ms: f64,
    },
    /// Right-skewed and bounded like the DS² synthesizer's delays.
    Skewed(SkewedDelay),
}

/// DS²'s delay shape the paper starts from: mean 100 ms, sd 70 ms, max 500 ms.
pub const DS2_MEAN_MS: f64 = 100.0;
pub const DS2_SD_MS: f64 = 70.0;
pub const DS2_MAX_MS: f64 = 500.0;

impl DelayDist {
    pub fn constant(ms: f64) -> Result<Self, ControlError> {
        if !(ms.is_finite() && ms >= 0.0) {
            return Err(ControlError::config(format!(
                "a constant delay must be a number of ms >= 0, got {ms}",
                ms = quote(ms)
            )));
        }
        Ok(Self::Constant { ms })
    }

    pub fn skewed(mean_ms: f64, sd_ms: f64, max_ms: f64) -> Result<Self, ControlError> {
        SkewedDelay::new(mean_ms, sd_ms, max_ms).map(Self::Skewed)
    }

    /// DS²'s shape with the time axis stretched by `scale` (the paper's 10..40
    /// give (μ, σ, max) = (1, 0.7, 5) .. (4, 2.8, 20) s).
    pub fn ds2_scaled(scale: f64) -> Result<Self, ControlError> {
        let scale = positive(scale, "delay scale")?;
        Self::skewed(DS2_MEAN_MS * scale, DS2_SD_MS * scale, DS2_MAX_MS * scale)
    }

    pub fn sample_ms(&self, rng: &mut Rng) -> f64 {
        match self {
            Self::Constant { ms } => *ms,
            Self::Skewed(skewed) => skewed.sample_ms(rng),
        }
    }

    pub fn mean_ms(&self) -> f64 {
        match self {
            Self::Constant { ms } => *ms,
            Self::Skewed(skewed) => skewed.mean_ms,
        }
    }

    pub fn sd_ms(&self) -> f64 {
        match self {
            Self::Constant { .. } => 0.0,
            Self::Skewed(skewed) => skewed.sd_ms,
        }
    }

    pub fn max_ms(&self) -> f64 {
        match self {
            Self::Constant { ms } => *ms,
            Self::Skewed(skewed) => skewed.max_ms,
        }
    }
}

/// A lognormal cut at `max_ms` (over-long draws are drawn again), whose
/// underlying parameters are fitted so that the delays actually produced
/// have the requested mean and sd: cutting the tail alone would lower both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkewedDelay {
    mean_ms: f64,
    sd_ms: f64,
    max_ms: f64,
    log_mean: f64,
    log_sd: f64,
}

/// Below this share of draws under the cap, rejection sampling gets slow and
/// the shape is no longer a skewed hump but a wall at the cap.
const MIN_ACCEPTED_SHARE: f64 = 0.5;

impl SkewedDelay {
    pub fn new(mean_ms: f64, sd_ms: f64, max_ms: f64) -> Result<Self, ControlError> {
        let mean_ms = positive(mean_ms, "delay mean (ms)")?;
        let sd_ms = positive(sd_ms, "delay standard deviation (ms)")?;
        let max_ms = positive(max_ms, "delay maximum (ms)")?;
        if max_ms <= mean_ms + sd_ms {
            return Err(ControlError::config(format!(
                "delay maximum {max_ms} ms must exceed mean + sd = {} ms for a right-skewed shape",
                quote(mean_ms + sd_ms),
                max_ms = quote(max_ms)
            )));
        }
        // Fixed point: scale the untruncated mean and sd by how far the
        // truncated ones fall short; the correction is small, so it converges fast.
        let (mut m, mut s) = (mean_ms, sd_ms);
        for _ in 0..200 {
            let (log_mean, log_sd) = lognormal_parameters(m, s);
            let (tm, ts, _) = truncated_moments(log_mean, log_sd, max_ms);
            if ((tm - mean_ms) / mean_ms).abs() < 1e-10 && ((ts - sd_ms) / sd_ms).abs() < 1e-10 {
                break;
            }
            m *= mean_ms / tm;
            s *= sd_ms / ts;
            if !(m.is_finite() && s.is_finite()) {
                break;
            }
        }
        let (log_mean, log_sd) = lognormal_parameters(m, s);
        let (tm, ts, accepted) = truncated_moments(log_mean, log_sd, max_ms);
        let fitted = ((tm - mean_ms) / mean_ms).abs() < 1e-6 && ((ts - sd_ms) / sd_ms).abs() < 1e-6;
        if !fitted || accepted < MIN_ACCEPTED_SHARE {
            return Err(ControlError::config(format!(
                "no skewed delay has mean {mean_ms} ms and sd {sd_ms} ms under a maximum of {max_ms} ms; raise the maximum or lower the sd",
                mean_ms = quote(mean_ms),
                sd_ms = quote(sd_ms),
                max_ms = quote(max_ms)
            )));
        }
        Ok(Self {
            mean_ms,
            sd_ms,
            max_ms,
            log_mean,
            log_sd,
        })
    }

    pub fn sample_ms(&self, rng: &mut Rng) -> f64 {
        loop {
            let delay = (self.log_mean + self.log_sd * rng.normal()).exp();
            if delay <= self.max_ms {
                return delay;
            }
        }
    }
}

/// (μ, σ) of ln X for a lognormal X with the given mean and sd.
fn lognormal_parameters(mean: f64, sd: f64) -> (f64, f64) {
    let variance = (1.0 + (sd / mean).powi(2)).ln();
    (mean.ln() - variance / 2.0, variance.sqrt())
}

/// Mean, sd and probability mass of a lognormal(μ, σ) kept below `cap`:
/// E[X^k; X < c] = exp(kμ + k²σ²/2) Φ((ln c - μ - kσ²)/σ).
fn truncated_moments(mu: f64, sigma: f64, cap: f64) -> (f64, f64, f64) {
    let z = |k: f64| normal_cdf((cap.ln() - mu - k * sigma * sigma) / sigma);
    let mass = z(0.0);
    let first = (mu + sigma * sigma / 2.0).exp() * z(1.0) / mass;
    let second = (2.0 * mu + 2.0 * sigma * sigma).exp() * z(2.0) / mass;
    (first, (second - first * first).max(0.0).sqrt(), mass)
}

fn normal_cdf(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

/// Complementary error function (Numerical Recipes' Chebyshev fit, relative error < 1.2e-7).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let value = t * poly.exp();
    if x >= 0.0 {
        value
    } else {
        2.0 - value
    }
}

/// A first-order process with dead time: τ dy/dt = K·(u(t - θ) + d(t)) - y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstOrderParams {
    pub gain: f64,
    pub tau_s: f64,
    pub dead_time_s: f64,
}

/// The process stepped exactly for inputs held between steps (zero-order hold),
/// with any dead time, not only whole steps, and steps of any length.
#[derive(Clone, Debug)]
pub struct FirstOrderProcess {
    params: FirstOrderParams,
    output: f64,
    elapsed_s: f64,
    /// (start time, value) of each input held, oldest first; the first starts at -∞.
    inputs: VecDeque<(f64, f64)>,
}

/// Absorbs rounding in summed step times so an input change is not missed by 1e-16 s.
const TIME_EPSILON_S: f64 = 1e-9;

impl FirstOrderProcess {
    /// Starts at rest at `initial_output`, as if the matching input had always been applied.
    pub fn new(params: FirstOrderParams, initial_output: f64) -> Result<Self, ControlError> {
        if !(params.gain.is_finite() && params.gain != 0.0) {
            return Err(ControlError::config(format!(
                "process gain must be a non-zero number, got {}",
                quote(params.gain)
            )));
        }
        positive(params.tau_s, "process time constant (s)")?;
        if !(params.dead_time_s.is_finite() && params.dead_time_s >= 0.0) {
            return Err(ControlError::config(format!(
                "process dead time must be a number of seconds >= 0, got {}",
                quote(params.dead_time_s)
            )));
        }
        let output = finite(initial_output, "initial output")
            .map_err(|e| ControlError::config(e.to_string()))?;
        Ok(Self {
            params,
            output,
            elapsed_s: 0.0,
            inputs: VecDeque::from([(f64::NEG_INFINITY, output / params.gain)]),
        })
    }

    pub fn params(&self) -> FirstOrderParams {
        self.params
    }

    pub fn output(&self) -> f64 {
        self.output
    }

    /// Applies `input` (reaching the output θ later) and `disturbance` (a load
    /// on the process itself, so without the dead time) for `dt_s`; returns the output after.
    pub fn step(&mut self, input: f64, disturbance: f64, dt_s: f64) -> Result<f64, ControlError> {
        let input = finite(input, "process input")?;
        let disturbance = finite(disturbance, "disturbance")?;
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(ControlError::input(format!(
                "a process step must last > 0 s, got {dt_s}",
                dt_s = quote(dt_s)
            )));
        }
        let FirstOrderParams {
            gain,
            tau_s,
            dead_time_s,
        } = self.params;
        if self.inputs.back().is_none_or(|&(_, last)| last != input) {
            self.inputs.push_back((self.elapsed_s, input));
        }
        let end = self.elapsed_s + dt_s;
        let mut t = self.elapsed_s;
        while t < end {
            let source = t - dead_time_s;
            let active = self
                .inputs
                .partition_point(|&(start, _)| start <= source + TIME_EPSILON_S);
            // The first entry starts at -∞, so `active` >= 1.
            let held = self.inputs[active - 1].1;
            let segment_end = self
                .inputs
                .get(active)
                .map_or(end, |&(start, _)| (start + dead_time_s).min(end));
            let target = gain * (held + disturbance);
            self.output = target + (self.output - target) * (-(segment_end - t) / tau_s).exp();
            t = segment_end;
        }
        self.elapsed_s = end;
        // Inputs that can no longer reach the output are dropped, bounding memory by θ / dt.
        while self.inputs.len() >= 2 && self.inputs[1].0 <= end - dead_time_s {
            self.inputs.pop_front();
        }
        Ok(self.output)
    }
}

/// One direction of a TCP connection: packets arrive in the order sent, each
/// after its own drawn delay but never before the packet ahead of it.
#[derive(Clone, Debug)]
pub struct Link<T> {
    delay: DelayDist,
    rng: Rng,
    up: bool,
    /// (delivery time, packet), delivery times non-decreasing.
    in_flight: VecDeque<(f64, T)>,
    last_delivery_ms: f64,
}

impl<T> Link<T> {
    pub fn new(delay: DelayDist, seed: u64) -> Self {
        Self {
            delay,
            rng: Rng::new(seed),
            up: true,
            in_flight: VecDeque::new(),
            last_delivery_ms: f64::NEG_INFINITY,
        }
    }

    pub fn delay(&self) -> &DelayDist {
        &self.delay
    }

    pub fn is_up(&self) -> bool {
        self.up
    }

    /// Taking the link down breaks the connection: whatever is in flight is lost.
    pub fn set_up(&mut self, up: bool) {
        if !up {
            self.in_flight.clear();
            self.last_delivery_ms = f64::NEG_INFINITY;
        }
        self.up = up;
    }

    /// Sends with a drawn delay; returns the delivery time, or `None` when the link is down.
    pub fn send(&mut self, packet: T, now_ms: f64) -> Option<f64> {
        if !self.up {
            return None;
        }
        let delay_ms = self.delay.sample_ms(&mut self.rng);
        self.send_with_delay(packet, now_ms, delay_ms)
    }

    /// Sends with a given network delay (the packet still waits for those ahead of it).
    pub fn send_with_delay(&mut self, packet: T, now_ms: f64, delay_ms: f64) -> Option<f64> {
        if !self.up {
            return None;
        }
        let delivery = (now_ms + delay_ms).max(self.last_delivery_ms);
        self.last_delivery_ms = delivery;
        self.in_flight.push_back((delivery, packet));
        Some(delivery)
    }

    /// Every packet delivered by `now_ms`, oldest first.
    pub fn receive(&mut self, now_ms: f64) -> Vec<T> {
        let delivered = self.in_flight.partition_point(|&(at, _)| at <= now_ms);
        self.in_flight
            .drain(..delivered)
            .map(|(_, packet)| packet)
            .collect()
    }

    /// The newest packet delivered by `now_ms`: a receiver that writes each one to
    /// the same register keeps only the last of a batch (the paper's §7.3).
    pub fn receive_latest(&mut self, now_ms: f64) -> Option<T> {
        self.receive(now_ms).pop()
    }

    pub fn in_flight(&self) -> usize {
        self.in_flight.len()
    }
}

/// Something that fails or comes back; ids are the caller's (controller id, link index).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Failure {
    ControllerDown(usize),
    ControllerUp(usize),
    LinkDown(usize),
    LinkUp(usize),
}

/// Failures and recoveries at given times (ms). Everything is up until an event says otherwise.
#[derive(Clone, Debug, Default)]
pub struct FailureSchedule {
    events: Vec<(f64, Failure)>,
    next: usize,
}

impl FailureSchedule {
    pub fn new(mut events: Vec<(f64, Failure)>) -> Result<Self, ControlError> {
        if let Some((at, _)) = events.iter().find(|(at, _)| !at.is_finite()) {
            return Err(ControlError::config(format!(
                "a failure time must be a number of ms, got {at}",
                at = quote(at)
            )));
        }
        // Stable: events at the same time keep the order given.
        events.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(Self { events, next: 0 })
    }

    pub fn events(&self) -> &[(f64, Failure)] {
        &self.events
    }

    /// Events at or before `now_ms` not yet returned, in time order.
    pub fn due(&mut self, now_ms: f64) -> Vec<Failure> {
        let start = self.next;
        while self.next < self.events.len() && self.events[self.next].0 <= now_ms {
            self.next += 1;
        }
        self.events[start..self.next]
            .iter()
            .map(|&(_, event)| event)
            .collect()
    }

    pub fn controller_up(&self, id: usize, at_ms: f64) -> bool {
        self.up_at(at_ms, |event| match event {
            Failure::ControllerDown(c) if c == id => Some(false),
            Failure::ControllerUp(c) if c == id => Some(true),
            _ => None,
        })
    }

    pub fn link_up(&self, link: usize, at_ms: f64) -> bool {
        self.up_at(at_ms, |event| match event {
            Failure::LinkDown(l) if l == link => Some(false),
            Failure::LinkUp(l) if l == link => Some(true),
            _ => None,
        })
    }

    fn up_at(&self, at_ms: f64, verdict: impl Fn(Failure) -> Option<bool>) -> bool {
        self.events
            .iter()
            .take_while(|(at, _)| *at <= at_ms)
            .filter_map(|&(_, event)| verdict(event))
            .last()
            .unwrap_or(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mean_and_sd(values: &[f64]) -> (f64, f64) {
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, variance.sqrt())
    }

    #[test]
    fn same_seed_same_sequence_other_seed_other_sequence() {
        let draw = |seed| {
            let mut rng = Rng::new(seed);
            (0..64).map(|_| rng.next_u64()).collect::<Vec<_>>()
        };
        assert_eq!(draw(7), draw(7));
        assert_ne!(draw(7), draw(8));
        let mut a = Rng::new(3);
        let mut b = Rng::new(3);
        for _ in 0..100 {
            assert_eq!(a.normal().to_bits(), b.normal().to_bits());
        }
    }

    #[test]
    fn uniform_and_normal_have_their_moments() {
        // 200 000 draws: the standard error of a mean is 1/sqrt(12·n) ≈ 0.0006 (uniform)
        // and 1/sqrt(n) ≈ 0.0022 (normal); the tolerances are several of those.
        let mut rng = Rng::new(42);
        let uniform: Vec<f64> = (0..200_000).map(|_| rng.uniform()).collect();
        assert!(uniform.iter().all(|u| (0.0..1.0).contains(u)));
        let (mean, sd) = mean_and_sd(&uniform);
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
        assert!((sd - (1.0f64 / 12.0).sqrt()).abs() < 0.005, "{sd}");
        let normal: Vec<f64> = (0..200_000).map(|_| rng.normal()).collect();
        let (mean, sd) = mean_and_sd(&normal);
        assert!(mean.abs() < 0.015, "{mean}");
        assert!((sd - 1.0).abs() < 0.015, "{sd}");
    }

    #[test]
    fn ds2_shaped_delays_have_the_papers_mean_sd_and_maximum() {
        // 200 000 draws: the mean's standard error is σ/sqrt(n) ≈ 0.16 % of μ, the sd's
        // under 0.5 % of σ; 1.5 % and 3 % leave room for chance but not for a shape
        // that ignores the cap (see the unfitted check below).
        for scale in [10.0, 20.0, 30.0, 40.0] {
            let dist = DelayDist::ds2_scaled(scale).unwrap();
            let mut rng = Rng::new(scale as u64);
            let draws: Vec<f64> = (0..200_000).map(|_| dist.sample_ms(&mut rng)).collect();
            let (mean, sd) = mean_and_sd(&draws);
            let (mu, sigma, max) = (100.0 * scale, 70.0 * scale, 500.0 * scale);
            assert!(
                ((mean - mu) / mu).abs() < 0.015,
                "scale {scale}: mean {mean} vs {mu}"
            );
            assert!(
                ((sd - sigma) / sigma).abs() < 0.03,
                "scale {scale}: sd {sd} vs {sigma}"
            );
            assert!(
                draws.iter().all(|&d| d > 0.0 && d <= max),
                "scale {scale}: a draw outside (0, {max}]"
            );
            let mut sorted = draws.clone();
            sorted.sort_by(f64::total_cmp);
            let median = sorted[sorted.len() / 2];
            assert!(
                median < mean,
                "right-skewed: median {median} under mean {mean}"
            );
            assert!(
                sorted[sorted.len() * 999 / 1000] > 3.0 * mu,
                "a long tail reaches far past the mean"
            );
        }
    }

    #[test]
    fn the_fit_corrects_what_the_cap_removes() {
        // A lognormal with the target moments, cut at 4μ, would come out with an sd
        // about 11 % below the target; the fitted one does not.
        let (mu, sigma, max) = (1000.0, 700.0, 4000.0);
        let (log_mean, log_sd) = lognormal_parameters(mu, sigma);
        let (_, naive_sd, _) = truncated_moments(log_mean, log_sd, max);
        assert!(
            naive_sd < 0.92 * sigma,
            "the cap alone shrinks the sd: {naive_sd}"
        );
        let dist = DelayDist::skewed(mu, sigma, max).unwrap();
        let mut rng = Rng::new(1);
        let draws: Vec<f64> = (0..200_000).map(|_| dist.sample_ms(&mut rng)).collect();
        let (mean, sd) = mean_and_sd(&draws);
        assert!(((mean - mu) / mu).abs() < 0.015, "{mean}");
        assert!(((sd - sigma) / sigma).abs() < 0.03, "{sd}");
    }

    #[test]
    fn refuses_delays_that_cannot_be_produced() {
        for (mean, sd, max) in [
            (0.0, 70.0, 500.0),
            (100.0, 0.0, 500.0),
            (100.0, 70.0, 150.0),
            (100.0, 70.0, f64::NAN),
            (100.0, 500.0, 700.0),
        ] {
            assert_eq!(
                DelayDist::skewed(mean, sd, max).unwrap_err().code(),
                "INVALID_CONFIG",
                "{mean} {sd} {max}"
            );
        }
        assert_eq!(
            DelayDist::constant(-1.0).unwrap_err().code(),
            "INVALID_CONFIG"
        );
        let mut rng = Rng::new(0);
        assert_eq!(
            DelayDist::constant(100.0).unwrap().sample_ms(&mut rng),
            100.0
        );
    }

    fn process(dead_time_s: f64) -> FirstOrderProcess {
        FirstOrderProcess::new(
            FirstOrderParams {
                gain: 2.0,
                tau_s: 3.0,
                dead_time_s,
            },
            0.0,
        )
        .unwrap()
    }

    #[test]
    fn step_response_reaches_63_percent_one_time_constant_after_the_dead_time() {
        // 0.35 s of dead time is not a whole number of 0.1 s steps.
        let mut p = process(0.35);
        let mut t = 0.0;
        while t < 0.35 - 1e-9 {
            let y = p.step(1.0, 0.0, 0.05).unwrap();
            t += 0.05;
            assert!(
                y.abs() < 1e-12,
                "nothing reaches the output within the dead time (t = {t})"
            );
        }
        // θ + τ = 3.35 s = 67 steps of 0.05 s.
        let mut p = process(0.35);
        for _ in 0..66 {
            p.step(1.0, 0.0, 0.05).unwrap();
        }
        let y = p.step(1.0, 0.0, 0.05).unwrap();
        assert!((y - 2.0 * (1.0 - (-1f64).exp())).abs() < 1e-9, "{y}");
        for _ in 0..1000 {
            p.step(1.0, 0.0, 0.1).unwrap();
        }
        assert!((p.output() - 2.0).abs() < 1e-9, "settles at the gain");
    }

    #[test]
    fn result_does_not_depend_on_the_step_length() {
        let inputs = [0.0, 1.0, -0.5, 2.0, 2.0, 0.25];
        let run = |dt: f64| {
            let mut p = process(0.73);
            let per_input = (0.6 / dt).round() as usize;
            for &u in &inputs {
                for _ in 0..per_input {
                    p.step(u, 0.1, dt).unwrap();
                }
            }
            p.output()
        };
        let coarse = run(0.3);
        assert!(
            (coarse - run(0.01)).abs() < 1e-9,
            "{coarse} vs {}",
            run(0.01)
        );
        assert!((coarse - run(0.6)).abs() < 1e-9);
    }

    #[test]
    fn a_disturbance_shifts_the_output_by_gain_times_load_without_the_dead_time() {
        let mut p = process(5.0);
        p.step(0.0, 0.5, 3.0).unwrap();
        let expected = 2.0 * 0.5 * (1.0 - (-1f64).exp());
        assert!((p.output() - expected).abs() < 1e-12, "{}", p.output());
    }

    #[test]
    fn starts_at_rest_and_refuses_bad_parameters() {
        let mut p = FirstOrderProcess::new(
            FirstOrderParams {
                gain: 0.5,
                tau_s: 1.0,
                dead_time_s: 1.0,
            },
            0.69,
        )
        .unwrap();
        for _ in 0..50 {
            assert!(
                (p.step(1.38, 0.0, 0.01).unwrap() - 0.69).abs() < 1e-12,
                "held input keeps it at rest"
            );
        }
        for params in [
            FirstOrderParams {
                gain: 0.0,
                tau_s: 1.0,
                dead_time_s: 0.0,
            },
            FirstOrderParams {
                gain: 1.0,
                tau_s: 0.0,
                dead_time_s: 0.0,
            },
            FirstOrderParams {
                gain: 1.0,
                tau_s: 1.0,
                dead_time_s: -1.0,
            },
        ] {
            assert_eq!(
                FirstOrderProcess::new(params, 0.0).unwrap_err().code(),
                "INVALID_CONFIG"
            );
        }
        assert_eq!(
            p.step(f64::NAN, 0.0, 0.1).unwrap_err().code(),
            "INVALID_INPUT"
        );
        assert_eq!(p.step(1.0, 0.0, 0.0).unwrap_err().code(), "INVALID_INPUT");
    }

    #[test]
    fn a_late_packet_holds_back_the_ones_behind_it_and_the_batch_keeps_the_last() {
        let mut link = Link::new(DelayDist::constant(0.0).unwrap(), 0);
        assert_eq!(link.send_with_delay("a", 0.0, 500.0), Some(500.0));
        assert_eq!(
            link.send_with_delay("b", 10.0, 50.0),
            Some(500.0),
            "b waits for a"
        );
        assert_eq!(link.send_with_delay("c", 20.0, 600.0), Some(620.0));
        assert_eq!(link.receive_latest(499.0), None);
        assert_eq!(
            link.receive_latest(500.0),
            Some("b"),
            "a and b arrive together; b is written last"
        );
        assert_eq!(link.receive(619.0), Vec::<&str>::new());
        assert_eq!(link.receive(620.0), vec!["c"]);
    }

    #[test]
    fn random_delays_never_reorder_packets() {
        let mut link = Link::new(DelayDist::ds2_scaled(40.0).unwrap(), 9);
        let mut received = Vec::new();
        let mut batches = 0;
        for ms in 0..200_000u32 {
            if ms % 300 == 0 {
                link.send(ms, f64::from(ms));
            }
            let batch = link.receive(f64::from(ms));
            batches += usize::from(batch.len() > 1);
            received.extend(batch);
        }
        assert!(received.windows(2).all(|w| w[0] < w[1]), "in order");
        assert!(
            received.len() > 600,
            "most packets arrived: {}",
            received.len()
        );
        assert!(
            batches > 10,
            "delays this variable make packets bunch up: {batches} batches"
        );
    }

    #[test]
    fn packets_sent_while_down_or_in_flight_at_the_failure_are_lost() {
        let mut link = Link::new(DelayDist::constant(100.0).unwrap(), 0);
        assert_eq!(link.send(1, 0.0), Some(100.0));
        link.set_up(false);
        assert_eq!(link.send(2, 50.0), None);
        assert_eq!(link.receive(1000.0), Vec::<i32>::new());
        link.set_up(true);
        assert_eq!(
            link.send(3, 1000.0),
            Some(1100.0),
            "a new connection waits for nothing old"
        );
        assert_eq!(link.receive(1100.0), vec![3]);
    }

    #[test]
    fn the_same_seed_gives_the_same_delivery_times() {
        let deliveries = |seed| {
            let mut link = Link::new(DelayDist::ds2_scaled(10.0).unwrap(), seed);
            (0..100)
                .map(|k| link.send((), f64::from(k) * 300.0).unwrap())
                .collect::<Vec<_>>()
        };
        assert_eq!(deliveries(5), deliveries(5));
        assert_ne!(deliveries(5), deliveries(6));
    }

    #[test]
    fn schedule_reports_events_once_in_time_order_and_knows_what_is_up() {
        let mut schedule = FailureSchedule::new(vec![
            (78_000.0, Failure::LinkUp(1)),
            (22_000.0, Failure::LinkDown(1)),
            (50_000.0, Failure::ControllerDown(2)),
        ])
        .unwrap();
        assert!(schedule.link_up(1, 21_999.0));
        assert!(!schedule.link_up(1, 22_000.0));
        assert!(schedule.link_up(1, 78_000.0));
        assert!(schedule.link_up(2, 50_000.0), "other links are unaffected");
        assert!(!schedule.controller_up(2, 90_000.0), "never recovered");
        assert!(schedule.controller_up(1, 90_000.0));
        assert_eq!(schedule.due(10_000.0), vec![]);
        assert_eq!(
            schedule.due(60_000.0),
            vec![Failure::LinkDown(1), Failure::ControllerDown(2)]
        );
        assert_eq!(
            schedule.due(60_000.0),
            vec![],
            "each event is reported once"
        );
        assert_eq!(schedule.due(1e9), vec![Failure::LinkUp(1)]);
        assert_eq!(
            FailureSchedule::new(vec![(f64::NAN, Failure::LinkUp(0))])
                .unwrap_err()
                .code(),
            "INVALID_CONFIG"
        );
    }
}
