//! lockstep runtime: plant, simulation, identification, diagnosis, control, reporting.
//!
//! The dynamics kernels come from the `generated` crate (built from `model/*.toml` by the
//! symbolic generator); this crate never depends on Symbolica.
// Index loops mirror the equations they implement.
#![allow(clippy::needless_range_loop)]

pub mod accuracy;
pub mod compare;
pub mod control;
pub mod demo;
pub mod diagnose;
pub mod effects;
pub mod excitation;
pub mod expression;
pub mod files;
pub mod identify;
pub mod measurement;
pub mod names;
pub mod plant;
pub mod report;
pub mod signal;
pub mod simulation;
pub mod synthetic;
pub mod util;
