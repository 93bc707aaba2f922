//! Identification. [`idim`]: inverse-dynamic model, linear least squares (IDIM-LS) for
//! torque-measured data. [`output_error`]: output-error fits of simulated positions to
//! measured ones (thesis Chapter 4). [`sequence`]: the locking sequences (method of
//! isolated joints, method of coupling joints). [`identifiability`]: parameter occurrence
//! per configuration and locking sequence, base parameters.
pub mod identifiability;
pub mod idim;
pub mod output_error;
pub mod sequence;
