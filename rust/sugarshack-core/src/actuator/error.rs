use std::fmt;

use crate::code::Code;
use crate::text::quote;
use crate::time::Millis;

/// Why a tracker call was refused. A refused command sends nothing.
#[derive(Clone, Debug, PartialEq)]
pub enum TrackError {
    /// The plant document has no actuator of that id.
    UnknownActuator {
        /// The name as given.
        name: String,
    },
    /// The plant document has no device of that id.
    UnknownDevice {
        /// The name as given.
        name: String,
    },
    /// The group command names no actuator.
    EmptyCommand,
    /// The group command cannot be read.
    InvalidGroup {
        /// Why, in words a person acts on.
        reason: String,
    },
    /// One actuator appears twice in a group command.
    DuplicateActuator {
        /// The actuator's id.
        actuator: String,
    },
    /// A target the actuator cannot take.
    InvalidTarget {
        /// The actuator's id.
        actuator: String,
        /// Why, in words a person acts on.
        reason: String,
    },
    /// The actuator is still carrying out an earlier command.
    StillMoving {
        /// The actuator's id.
        actuator: String,
    },
    /// The actuator's device is offline: the command could not arrive.
    DeviceOffline {
        /// The actuator's id.
        actuator: String,
        /// The device's id.
        device: String,
    },
    /// This caller's previous group command has not completed.
    CallerBusy {
        /// The caller's handle of the group command.
        caller: u64,
    },
    /// Feedback that is not a state the actuator can be in.
    InvalidFeedback {
        /// The actuator's id.
        actuator: String,
        /// The value given.
        value: f64,
    },
    /// C2: an operation commanded an actuator outside the resources it holds.
    OutsideResources {
        /// The actuator's id.
        actuator: String,
        /// The line's name.
        resource: Option<String>,
        /// The lines the operation holds.
        held: Vec<String>,
    },
    /// A normal command to an actuator whose lockout feedback has not confirmed.
    LockoutPending {
        /// The actuator's id.
        actuator: String,
    },
    /// A sample stamped further ahead of its reception than the plant's `clockSkewMs`.
    FutureTimestamp {
        /// The actuator's id.
        actuator: String,
        /// How far ahead of its reception the sample is stamped.
        ahead_ms: Millis,
        /// The plant's allowed clock skew.
        skew_ms: Millis,
    },
}

impl TrackError {
    /// A stable machine-readable code, for Catch nodes and tests.
    pub fn code(&self) -> Code {
        match self {
            Self::UnknownActuator { .. } => Code::UnknownActuator,
            Self::UnknownDevice { .. } => Code::UnknownDevice,
            Self::EmptyCommand => Code::EmptyCommand,
            Self::InvalidGroup { .. } => Code::InvalidGroup,
            Self::DuplicateActuator { .. } => Code::DuplicateActuator,
            Self::InvalidTarget { .. } => Code::InvalidTarget,
            Self::StillMoving { .. } => Code::StillMoving,
            Self::DeviceOffline { .. } => Code::DeviceOffline,
            Self::CallerBusy { .. } => Code::CallerBusy,
            Self::InvalidFeedback { .. } => Code::InvalidFeedback,
            Self::OutsideResources { .. } => Code::OutsideResources,
            Self::LockoutPending { .. } => Code::LockoutPending,
            Self::FutureTimestamp { .. } => Code::FutureTimestamp,
        }
    }
}

impl fmt::Display for TrackError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnknownActuator { name } => write!(f, "unknown actuator '{}': it is not in the plant document", quote(name)),
            Self::UnknownDevice { name } => write!(f, "unknown device '{}': it is not in the plant document", quote(name)),
            Self::EmptyCommand => write!(f, "the group command names no actuator"),
            Self::InvalidGroup { reason } => write!(f, "invalid group command: {reason}"),
            Self::DuplicateActuator { actuator } => write!(f, "actuator '{actuator}' appears twice in one group command"),
            Self::InvalidTarget { actuator, reason } => write!(f, "target for '{actuator}' {reason}"),
            Self::StillMoving { actuator } => write!(
                f,
                "actuator '{actuator}' is still carrying out a command; wait for it to complete (nothing was sent)"
            ),
            Self::DeviceOffline { actuator, device } => {
                write!(f, "actuator '{actuator}' cannot be commanded: its device '{device}' is offline (nothing was sent)")
            }
            Self::CallerBusy { caller } => write!(f, "group command #{caller} is already in progress"),
            Self::InvalidFeedback { actuator, value } => write!(f, "feedback {value} for '{actuator}' is not a valid state"),
            Self::OutsideResources { actuator, resource, held } => {
                let on = resource.as_deref().map_or("belongs to no resource".to_string(), |r| format!("is on resource '{r}'"));
                write!(f, "C2: actuator '{actuator}' {on}, outside the resources held ({}); nothing was sent", quote(held.join(", ")))
            }
            Self::LockoutPending { actuator } => write!(
                f,
                "actuator '{actuator}' has not yet confirmed its lockout state; it is re-sent until feedback shows it there, check the device if that takes long (nothing was sent)"
            ),
            Self::FutureTimestamp { actuator, ahead_ms, skew_ms } => write!(
                f,
                "feedback for '{actuator}' is stamped {ahead_ms} ms ahead of its reception, more than clockSkewMs ({skew_ms} ms): set the device's clock (nothing of it was applied)"
            ),
        }
    }
}

impl std::error::Error for TrackError {}
