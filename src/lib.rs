//! ember: a physically based path tracer on Intel Embree.
//!
//! Data flows one way: scene file → [`scene`] → [`accel`] (Embree or the naive loop) →
//! integrator → film → image file. Lower modules never import higher ones; the FFI layers
//! [`embree`] and [`oidn`] (the denoiser) are the only modules with unchecked (FFI) code.

#![deny(unsafe_op_in_unsafe_fn)]
// `!(x > 0.0)` is written on purpose where NaN must take the "no" branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod atomic_write;
pub mod camera;
pub mod choice;
pub mod embree;
pub mod fastmath;
pub mod film;
pub mod geometry;
pub mod hash;
pub mod integrator;
pub mod jpeg_scan;
pub mod light;
pub mod material;
pub mod memory;
pub mod oidn;
pub mod output_lock;
pub mod posix;
pub mod regular_file;
pub mod sampler;
pub mod scene;
pub mod settings;
pub mod texture;
pub mod tools;
