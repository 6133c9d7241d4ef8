//! Pure numerical kernels: B-splines, Savitzky-Golay, rotations, type conversions,
//! quantiles, the exact sign test.
//!
//! Nothing here knows about demonstrations or robots; every kernel has its own unit tests.

pub mod bspline;
pub mod convert;
pub mod quantile;
pub mod rotation;
pub mod savgol;
pub mod sign_test;
