//! The cloud-control paper's experiments (Tables 2 and 3, Figs. 11 and 12) run
//! on sugarshack's control core and plant simulator: redundant controllers under
//! RCC through a controller failure, and a Smith-predicted PI under large random
//! round trips. Deterministic: every run is fixed by its seed.

pub mod delay_compensation;
pub mod fault_tolerance;
pub mod metrics;
pub mod sim;
pub mod svg;
pub mod tuning;
