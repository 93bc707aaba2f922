//! Identification. [`idim`]: inverse-dynamic model, linear least squares (IDIM-LS) for
//! torque-measured data.
pub mod idim;
