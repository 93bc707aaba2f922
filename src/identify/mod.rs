//! Identification. [`idim`]: inverse-dynamic model, linear least squares (IDIM-LS) for
//! torque-measured data. [`identifiability`]: parameter occurrence per configuration and
//! locking sequence, base parameters.
pub mod identifiability;
pub mod idim;
