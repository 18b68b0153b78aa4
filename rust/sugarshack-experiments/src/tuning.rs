//! Ziegler-Nichols' reaction-curve rule (the paper's [38]) for a PI controller.

/// PI settings in the core's standard form: P = kp·e, I = (kp/ti)·∫e dt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiTuning {
    pub kp: f64,
    pub ti_s: f64,
}

/// The rule for a first-order process with dead time as the controller sees it
/// (gain K, time constant τ, apparent dead time L): kp = 0.9·τ/(K·L), ti = L/0.3.
pub fn ziegler_nichols_pi(gain: f64, tau_s: f64, dead_time_s: f64) -> PiTuning {
    PiTuning {
        kp: 0.9 * tau_s / (gain * dead_time_s),
        ti_s: dead_time_s / 0.3,
    }
}

/// The dead time a sampled remote loop adds to the process: the round trip from
/// the sensor read to the action written, plus half a sample for the zero-order
/// hold of the action.
pub fn apparent_dead_time_s(round_trip_s: f64, ts_s: f64, process_dead_time_s: f64) -> f64 {
    process_dead_time_s + round_trip_s + ts_s / 2.0
}

/// The gain that puts the crossover (|C·P| = 1) of a PI with integral time
/// `ti_s` on K/(τs + 1) at `crossover_rad_s`. Below crossover the loop
/// follows the set point; above it it ignores what happens, so ω_c sets both
/// the speed of the response (time constant ≈ 1/ω_c) and what model errors it tolerates.
pub fn gain_for_crossover(gain: f64, tau_s: f64, ti_s: f64, crossover_rad_s: f64) -> f64 {
    let w = crossover_rad_s;
    (1.0 + (w * tau_s).powi(2)).sqrt() / (gain * (1.0 + 1.0 / (w * ti_s).powi(2)).sqrt())
}
