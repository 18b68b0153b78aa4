//! The paper's round-trip delay estimator (§4): exponentially weighted mean and
//! variance, and the compensator's dead time D_c = floor((D + h·sqrt V) / Ts),
//! which follows a change of delay without overreacting to a single spike.

use super::error::{positive_duration, ControlError};
use crate::text::quote;
use crate::time::{ms, Millis};

/// Longest round trip taken (a day): beyond it a sample is an error, and one
/// absurd value could otherwise hold the variance at infinity for ever.
pub const MAX_ROUND_TRIP: Millis = ms(86_400_000);

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

    /// A measured round trip of `ms` milliseconds, refused unless from 0 to a day.
    pub fn round_trip(ms: f64) -> Result<Millis, ControlError> {
        Millis::new(ms)
            .filter(|rt| *rt <= MAX_ROUND_TRIP)
            .ok_or_else(|| {
                ControlError::input(format!(
                    "a round trip must be a number of milliseconds from 0 to {MAX_ROUND_TRIP} (a day), got {ms}",
                    ms = quote(ms)
                ))
            })
    }

    /// Takes one measured round trip, refused beyond a day.
    pub fn observe(&mut self, round_trip: Millis) -> Result<(), ControlError> {
        let round_trip_ms = Self::round_trip(round_trip.as_f64())?.as_f64();
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

    /// The mean round trip so far.
    pub fn mean(&self) -> Option<Millis> {
        // A weighted mean of round trips from 0 to a day is one too.
        self.mean_ms.and_then(Millis::new)
    }

    /// The standard deviation of the round trip so far.
    pub fn std(&self) -> Option<Millis> {
        self.mean_ms
            .and_then(|_| Millis::new(self.variance_ms2.sqrt()))
    }

    /// Dead time in whole samples of `ts`; 0 before any round trip was seen.
    pub fn dead_time_samples(&self, ts: Millis) -> Result<usize, ControlError> {
        let ts_ms = positive_duration(ts.as_f64(), "sampling period")?.as_f64();
        let Some(mean) = self.mean_ms else {
            return Ok(0);
        };
        Ok(((mean + self.h * self.variance_ms2.sqrt()) / ts_ms).floor() as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::millis;

    #[test]
    fn follows_the_papers_recurrences() {
        let mut e = DelayEstimator::new(0.5, 3.0).unwrap();
        e.observe(millis(100.0)).unwrap();
        assert_eq!(
            (e.mean(), e.std()),
            (Some(millis(100.0)), Some(millis(0.0)))
        );
        e.observe(millis(300.0)).unwrap();
        // D = 0.5·300 + 0.5·100 = 200; V = 0.5·(300-200)² + 0.5·0 = 5000
        assert_eq!(e.mean(), Some(millis(200.0)));
        assert!((e.std().unwrap().as_f64() - 5000f64.sqrt()).abs() < 1e-9);
        // floor((200 + 3·70.71) / 100) = floor(4.12) = 4
        assert_eq!(e.dead_time_samples(millis(100.0)).unwrap(), 4);
    }

    #[test]
    fn no_sample_means_no_dead_time() {
        let e = DelayEstimator::new(0.1, 3.0).unwrap();
        assert_eq!(e.dead_time_samples(millis(300.0)).unwrap(), 0);
        assert_eq!(e.std(), None);
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
        for bad in [f64::NAN, -5.0, 1e308] {
            let refused = DelayEstimator::round_trip(bad).unwrap_err();
            assert_eq!(refused.code(), "INVALID_INPUT");
            assert!(refused.to_string().starts_with(
                "a round trip must be a number of milliseconds from 0 to 86400000 (a day)"
            ));
        }
        assert!(e.observe(millis(1e308)).is_err(), "longer than a day");
        assert_eq!(e.mean(), None, "a refused sample leaves the estimate alone");
        assert_eq!(
            e.dead_time_samples(millis(0.0)).unwrap_err().code(),
            "INVALID_CONFIG"
        );
    }

    #[test]
    fn a_round_trip_beyond_a_day_is_refused_so_one_cannot_pin_the_dead_time() {
        let mut e = DelayEstimator::new(0.5, 3.0).unwrap();
        e.observe(millis(100.0)).unwrap();
        assert_eq!(
            e.observe(millis(1e308)).unwrap_err().code(),
            "INVALID_INPUT"
        );
        assert_eq!(e.mean(), Some(millis(100.0)));
        // the longest accepted one decays away like any other spike
        e.observe(MAX_ROUND_TRIP).unwrap();
        for _ in 0..200 {
            e.observe(millis(100.0)).unwrap();
        }
        assert_eq!(e.dead_time_samples(millis(100.0)).unwrap(), 1);
    }
}
