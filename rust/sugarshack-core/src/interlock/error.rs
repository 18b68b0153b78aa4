use std::fmt;

use crate::code::Code;
use crate::text::quote;

/// Why an interlock call was refused. A refused call changes no state.
#[derive(Clone, Debug, PartialEq)]
pub enum InterlockError {
    /// The configuration cannot run.
    InvalidConfig {
        /// Why, in words a person acts on.
        reason: String,
    },
    /// The request names no resource.
    EmptyResourceSet,
    /// A resource the interlock is not configured with.
    UnknownResource {
        /// The name as given.
        name: String,
    },
    /// An operation that neither holds, waits, nor is named by a faulted line
    /// (never seen, released, or forgotten): there is nothing to fault.
    UnknownOperation {
        /// The name as given.
        name: String,
    },
    /// The paper's C1: one instance of an operation at a time.
    AlreadyHolding {
        /// The operation's id.
        operation: String,
    },
    /// C1: the operation already waits in the queue.
    AlreadyQueued {
        /// The operation's id.
        operation: String,
    },
    /// A release by an operation that holds nothing.
    NotHolding {
        /// The operation's id.
        operation: String,
    },
    /// A cancel of an operation that is not waiting.
    NotQueued {
        /// The operation's id.
        operation: String,
    },
    /// A clear of a line that is not faulted.
    NotFaulted {
        /// The line's name.
        resource: String,
    },
    /// The plant does not show the lines isolated yet: every reason, per line.
    ClearRefused {
        /// Each line that may not be cleared yet, with its reasons.
        lines: Vec<crate::clearance::LineBlockers>,
    },
    /// The queue is at its bound.
    QueueFull {
        /// The bound.
        bound: usize,
    },
    /// A saved state that cannot be restored.
    InvalidSnapshot {
        /// Why, in words a person acts on.
        reason: String,
    },
}

impl InterlockError {
    /// A stable machine-readable code, for Catch nodes and tests.
    pub fn code(&self) -> Code {
        match self {
            Self::InvalidConfig { .. } => Code::InvalidConfig,
            Self::EmptyResourceSet => Code::EmptyResourceSet,
            Self::UnknownResource { .. } => Code::UnknownResource,
            Self::UnknownOperation { .. } => Code::UnknownOperation,
            Self::AlreadyHolding { .. } => Code::AlreadyHolding,
            Self::AlreadyQueued { .. } => Code::AlreadyQueued,
            Self::NotHolding { .. } => Code::NotHolding,
            Self::NotQueued { .. } => Code::NotQueued,
            Self::NotFaulted { .. } => Code::NotFaulted,
            Self::ClearRefused { .. } => Code::ClearRefused,
            Self::QueueFull { .. } => Code::QueueFull,
            Self::InvalidSnapshot { .. } => Code::InvalidSnapshot,
        }
    }
}

impl fmt::Display for InterlockError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidConfig { reason } => write!(f, "invalid interlock configuration: {reason}"),
            Self::EmptyResourceSet => write!(f, "the request names no resource; give at least one"),
            Self::UnknownResource { name } => {
                write!(f, "unknown resource '{}': it is not configured in the interlock", quote(name))
            }
            Self::UnknownOperation { name } => {
                write!(f, "unknown operation '{}': it neither holds, waits for, nor faulted lines of this interlock", quote(name))
            }
            Self::AlreadyHolding { operation } => write!(
                f,
                "operation '{operation}' already holds its resources; one instance at a time (C1): release it first"
            ),
            Self::AlreadyQueued { operation } => write!(
                f,
                "operation '{operation}' is already waiting in the queue; one instance at a time (C1)"
            ),
            Self::NotHolding { operation } => {
                write!(f, "operation '{operation}' holds nothing to release")
            }
            Self::NotQueued { operation } => {
                write!(f, "operation '{operation}' is not waiting in the queue; nothing to cancel")
            }
            Self::NotFaulted { resource } => {
                write!(f, "line '{resource}' is not faulted; nothing to clear")
            }
            Self::ClearRefused { lines } => {
                write!(f, "clear refused: ")?;
                for (i, line) in lines.iter().enumerate() {
                    if i > 0 {
                        f.write_str(" | ")?;
                    }
                    write!(f, "{line}")?;
                }
                write!(f, "; clear once the plant shows the line isolated, or force it if you know it is safe")
            }
            Self::QueueFull { bound } => {
                write!(f, "the interlock queue is full ({bound} requests waiting); request refused")
            }
            Self::InvalidSnapshot { reason } => write!(
                f,
                "cannot restore interlock state: {reason}; nothing was restored, so treat every line's state as unknown until it is checked"
            ),
        }
    }
}

impl std::error::Error for InterlockError {}
