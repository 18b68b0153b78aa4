//! The paper's round-trip delay estimator (§4): exponentially weighted mean and
//! variance, and the compensator's dead time D_c = floor((D + h·sqrt V) / Ts),
//! which follows a change of delay without overreacting to a single spike.

use super::error::{positive_duration, ControlError};
use crate::text::quote;

/// Longest round trip taken (a day): beyond it a sample is an error, and one
/// absurd value could otherwise hold the variance at infinity for ever.
pub const MAX_ROUND_TRIP_MS: f64 = 86_400_000.0;

/// Estimates the network's round trip from observed samples: its mean and spread give the dead time the Smith predictor compensates.
#[derive(Clone, Debug, PartialEq)]
pub struct DelayEstimator {
    alpha: f64,
    h: f64,
    mean_ms: Option<f64>,
    variance_ms2: f64,
}

impl DelayEstimator {
    /// `alpha` in (0, 1] weighs the newest sample; `h` >= 0 is how many standard
    /// deviations above the mean the dead time covers.
    pub fn new(alpha: f64, h: f64) -> Result<Self, ControlError> {
        if !(alpha.is_finite() && alpha > 0.0 && alpha <= 1.0) {
            return Err(ControlError::config(format!(
                "delay estimator alpha must be in (0, 1], got {alpha}",
                alpha = quote(alpha)
            )));
        }
        if !(h.is_finite() && h >= 0.0) {
            return Err(ControlError::config(format!(
                "delay estimator h must be a number >= 0, got {h}",
                h = quote(h)
            )));
        }
        Ok(Self {
            alpha,
            h,
            mean_ms: None,
            variance_ms2: 0.0,
        })
    }

    /// Takes one measured round trip, in ms.
    pub fn observe(&mut self, round_trip_ms: f64) -> Result<(), ControlError> {
        if !(round_trip_ms.is_finite() && (0.0..=MAX_ROUND_TRIP_MS).contains(&round_trip_ms)) {
            return Err(ControlError::input(format!(
                "a round trip must be a number of milliseconds from 0 to {MAX_ROUND_TRIP_MS} (a day), got {round_trip_ms}",
                round_trip_ms = quote(round_trip_ms)
            )));
        }
        let a = self.alpha;
        match self.mean_ms {
            None => self.mean_ms = Some(round_trip_ms),
            Some(previous) => {
                let mean = a * round_trip_ms + (1.0 - a) * previous;
                self.variance_ms2 =
                    a * (round_trip_ms - mean).powi(2) + (1.0 - a) * self.variance_ms2;
                self.mean_ms = Some(mean);
            }
        }
        Ok(())
    }

    /// The mean round trip so far, in ms.
    pub fn mean_ms(&self) -> Option<f64> {
        self.mean_ms
    }

    /// The standard deviation of the round trip so far, in ms.
    pub fn std_ms(&self) -> Option<f64> {
        self.mean_ms.map(|_| self.variance_ms2.sqrt())
    }

    /// Dead time in whole samples of `ts_ms`; 0 before any round trip was seen.
    pub fn dead_time_samples(&self, ts_ms: f64) -> Result<usize, ControlError> {
        let ts_ms = positive_duration(ts_ms, "sampling period")?;
        let Some(mean) = self.mean_ms else {
            return Ok(0);
        };
        Ok(((mean + self.h * self.variance_ms2.sqrt()) / ts_ms).floor() as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follows_the_papers_recurrences() {
        let mut e = DelayEstimator::new(0.5, 3.0).unwrap();
        e.observe(100.0).unwrap();
        assert_eq!((e.mean_ms(), e.std_ms()), (Some(100.0), Some(0.0)));
        e.observe(300.0).unwrap();
        // D = 0.5·300 + 0.5·100 = 200; V = 0.5·(300-200)² + 0.5·0 = 5000
        assert_eq!(e.mean_ms(), Some(200.0));
        assert!((e.std_ms().unwrap() - 5000f64.sqrt()).abs() < 1e-9);
        // floor((200 + 3·70.71) / 100) = floor(4.12) = 4
        assert_eq!(e.dead_time_samples(100.0).unwrap(), 4);
    }

    #[test]
    fn no_sample_means_no_dead_time() {
        let e = DelayEstimator::new(0.1, 3.0).unwrap();
        assert_eq!(e.dead_time_samples(300.0).unwrap(), 0);
        assert_eq!(e.std_ms(), None);
    }

    #[test]
    fn refuses_bad_parameters_and_samples() {
        assert_eq!(
            DelayEstimator::new(0.0, 3.0).unwrap_err().code(),
            "INVALID_CONFIG"
        );
        assert_eq!(
            DelayEstimator::new(1.5, 3.0).unwrap_err().code(),
            "INVALID_CONFIG"
        );
        assert_eq!(
            DelayEstimator::new(0.2, -1.0).unwrap_err().code(),
            "INVALID_CONFIG"
        );
        let mut e = DelayEstimator::new(0.2, 3.0).unwrap();
        assert_eq!(e.observe(f64::NAN).unwrap_err().code(), "INVALID_INPUT");
        assert_eq!(e.observe(-5.0).unwrap_err().code(), "INVALID_INPUT");
        assert_eq!(
            e.mean_ms(),
            None,
            "a refused sample leaves the estimate alone"
        );
        assert_eq!(
            e.dead_time_samples(0.0).unwrap_err().code(),
            "INVALID_CONFIG"
        );
    }

    #[test]
    fn a_round_trip_beyond_a_day_is_refused_so_one_cannot_pin_the_dead_time() {
        let mut e = DelayEstimator::new(0.5, 3.0).unwrap();
        e.observe(100.0).unwrap();
        assert_eq!(e.observe(1e308).unwrap_err().code(), "INVALID_INPUT");
        assert_eq!(e.mean_ms(), Some(100.0));
        // the longest accepted one decays away like any other spike
        e.observe(MAX_ROUND_TRIP_MS).unwrap();
        for _ in 0..200 {
            e.observe(100.0).unwrap();
        }
        assert_eq!(e.dead_time_samples(100.0).unwrap(), 1);
    }
}
