//! The export tests as their own small binary, built only with the `robomimic` feature: CI
//! runs them so (with the HDF5 file read back in Rust and with h5py) without building the
//! whole `it` binary a second time. The same tests are in `it` (`export::`).

#[allow(dead_code)]
#[path = "it/fixtures.rs"]
mod fixtures;

#[path = "it/export.rs"]
mod export;
