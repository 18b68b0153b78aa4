//! Feedback control for loops run away from the plant (the cloud-automation
//! paper): a PID with exact bumpless transfer, an adaptive Smith predictor
//! whose dead time follows the measured round trip, RCC redundancy between
//! controllers that share no clock. The plant simulator the experiments run
//! them against lives in the experiments crate.

pub mod delay;
/// The refusal every control call returns, and the input checks they share.
pub mod error;
pub mod pid;
pub mod pid_loop;
pub mod rcc;
pub mod smith;
pub mod station;

pub use error::ControlError;
