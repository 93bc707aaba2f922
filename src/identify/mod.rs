//! Identification. [`idim`]: inverse-dynamic model, linear least squares (IDIM-LS) for
//! torque-measured data. [`output_error`]: output-error fits of simulated positions to
//! measured ones (thesis Chapter 4). [`sequence`]: the locking sequences (method of
//! isolated joints, method of coupling joints). [`refit`]: chosen parameters refitted after a
//! change, with the error per joint before and after. [`identifiability`]: parameter occurrence
//! per configuration and locking sequence, base parameters. [`equation_error`]: the torque
//! balance at every sample from the measured motion, the cheap warm start of an
//! output-error fit. [`joint`]: the joint fit of a locking sequence's steps, every
//! parameter on every step's files at once.
pub mod consistent;
pub mod didim;
pub mod equation_error;
pub mod identifiability;
pub mod idim;
pub mod joint;
pub mod output_error;
pub mod preparation;
pub mod refit;
pub mod sequence;
