//! The safe Embree layer: the only module of ember with `unsafe` code.
//!
//! - [`Device`]: an Embree device; Embree errors become [`EmbreeError`] values, never aborts.
//! - [`SceneBuilder`]: add triangle meshes and user geometry (any [`Shape`] array, with Rust
//!   bounds/intersect/occluded callbacks), choose build quality and flags, then
//!   [`SceneBuilder::commit`] into an immutable, thread-shareable [`Scene`] answering
//!   closest-hit and occlusion queries.
//!
//! The layer builds on Embree 3 (default: bindgen from Debian's headers) or Embree 4 (cargo
//! feature `embree4`: the `embree4-sys` crate); only `ffi.rs` knows which. The running
//! library's ray-hit memory layout is decided from its version when a [`Device`] is created
//! (`layout.rs`), and unknown versions are refused.
//!
//! Hazards of calling Embree from Rust (see `docs/embree-notes.md`) are ruled out here by
//! construction: ray masks and `geomID` are always initialised, vertex buffers are allocated by
//! Embree (with its padding) rather than shared, user data is boxed and owned by the scene,
//! panics in callbacks are caught, and handles keep what they depend on alive.
//!
//! [`Shape`]: crate::geometry::Shape

mod device;
mod error;
mod ffi;
mod kernels;
mod layout;
mod packet;
mod probe;
mod scene;
mod user;

pub use device::Device;
pub use error::{EmbreeError, ErrorCode};
pub use kernels::Kernels;
pub use layout::{EmbreeVersion, RayHitLayout};
pub use packet::LANES;
pub use probe::{GUARD, GuardProbe, PACKET_COMMON_WORDS, PROBE_WORDS, PacketProbe};
pub use scene::{BuildOptions, BuildQuality, Scene, SceneBuilder};

/// `RTC_INVALID_GEOMETRY_ID`: the id Embree reports for "no geometry / no instance".
pub const INVALID_ID: u32 = ffi::INVALID_GEOMETRY_ID;
