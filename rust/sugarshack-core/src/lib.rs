#![warn(missing_docs)]
//! The pure core of sugarshack: no clock, no I/O, no JS. Time comes in as an
//! argument in milliseconds ([`time::Millis`]); effects (grants, lockout commands, events) go out
//! as returned values, so every rule here is deterministic and testable natively.

pub mod actuator;
pub mod alarm;
pub mod clearance;
pub mod code;
pub mod condition;
pub mod control;
pub mod engine;
pub mod interlock;
pub mod json;
pub mod operation;
pub mod plant;
pub mod procedure;
pub mod routine;
pub mod sealed;
pub mod sensor;
pub mod text;
pub mod time;
pub mod topics;
