//! Pure numerical kernels: B-splines, Savitzky-Golay, rotations, type conversions.
//!
//! Nothing here knows about demonstrations or robots; every kernel has its own unit tests.

pub mod bspline;
pub mod convert;
pub mod rotation;
pub mod savgol;
