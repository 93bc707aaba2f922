//! lockstep runtime: plant, simulation, identification, diagnosis, control, reporting.
pub mod effects;
pub mod identify;
pub mod measurement;
pub mod plant;
pub mod signal;
pub mod util;
