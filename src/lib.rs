//! ember: a physically based path tracer on Intel Embree.
//!
//! Data flows one way: scene file → [`scene`] → [`accel`] (Embree or the naive loop) →
//! integrator → film → image file. Lower modules never import higher ones; all `unsafe` code
//! lives in [`embree`].

#![deny(unsafe_op_in_unsafe_fn)]

pub mod accel;
pub mod camera;
pub mod cli;
pub mod embree;
pub mod film;
pub mod geometry;
pub mod sampler;
pub mod scene;
