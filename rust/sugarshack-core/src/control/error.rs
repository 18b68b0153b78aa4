use std::fmt;

use crate::code::Code;
use crate::text::{quote, seconds};
use crate::time::Millis;

/// What a control call refused, with a message a process engineer can act on.
#[derive(Clone, Debug, PartialEq)]
pub enum ControlError {
    /// A configuration that cannot run (limits inverted, Ts <= 0, thresholds out of order).
    InvalidConfig(String),
    /// A step input that cannot be used (dt <= 0, a set point that is not a number).
    InvalidInput(String),
    /// An id outside the configured controllers.
    UnknownController {
        /// The id given.
        id: usize,
        /// How many controllers are configured.
        controllers: usize,
    },
}

impl ControlError {
    /// The code a Catch node sees.
    pub fn code(&self) -> Code {
        match self {
            Self::InvalidConfig(_) => Code::InvalidConfig,
            Self::InvalidInput(_) => Code::InvalidInput,
            Self::UnknownController { .. } => Code::UnknownController,
        }
    }

    /// An [`Self::InvalidConfig`] with `message`.
    pub fn config(message: impl Into<String>) -> Self {
        Self::InvalidConfig(message.into())
    }

    /// An [`Self::InvalidInput`] with `message`.
    pub fn input(message: impl Into<String>) -> Self {
        Self::InvalidInput(message.into())
    }
}

impl fmt::Display for ControlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidConfig(m) | Self::InvalidInput(m) => f.write_str(m),
            Self::UnknownController { id, controllers } => write!(
                f,
                "controller id {id} is not one of the {controllers} configured (ids run from 1 to {controllers})"
            ),
        }
    }
}

impl std::error::Error for ControlError {}

/// `value` must be a finite number; `what` names it in the error.
pub fn finite(value: f64, what: &str) -> Result<f64, ControlError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ControlError::input(format!(
            "{what} must be a finite number, got {value}",
            value = quote(value)
        )))
    }
}

/// `ms` as a [`Millis`]: a step input, refused unless finite and at least 0.
pub fn time(ms: f64, what: &str) -> Result<Millis, ControlError> {
    let ms = finite(ms, what)?;
    Millis::new(ms).ok_or_else(|| {
        ControlError::input(format!(
            "{what} must be at least 0 ms, got {value}",
            value = quote(ms)
        ))
    })
}

/// `ms` as a duration > 0; `what` names it in the error, worded in seconds.
pub fn positive_duration(ms: f64, what: &str) -> Result<Millis, ControlError> {
    Millis::new(ms)
        .filter(|d| *d > Millis::ZERO)
        .ok_or_else(|| {
            ControlError::config(format!(
                "{what} must be greater than 0 s, got {}",
                seconds(ms)
            ))
        })
}

/// `value` must be a finite number > 0; `what` names it in the error.
pub fn positive(value: f64, what: &str) -> Result<f64, ControlError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ControlError::config(format!(
            "{what} must be a number greater than 0, got {value}",
            value = quote(value)
        )))
    }
}

/// A result computed from accepted inputs that left the range of numbers: the
/// step is refused before anything becomes state.
pub(crate) fn computed(value: f64, what: &str) -> Result<f64, ControlError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(out_of_range(value, what))
    }
}

/// The error of [`computed`] for `value`.
pub(crate) fn out_of_range(value: f64, what: &str) -> ControlError {
    ControlError::input(format!(
        "the {what} came out as {value}: the inputs are beyond what this loop can compute with; nothing was changed",
        value = quote(value)
    ))
}
