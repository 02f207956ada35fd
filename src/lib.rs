//! granpack: dense random packs of discs (2D) and spheres (3D), made layer by layer
//! (random sequential addition, then a DEM jamming run under gravity), as in Campello &
//! Cassares' technique.
//!
//! Map of the crate:
//! - [`math`]: the dimension trait (`Dim<2>`, `Dim<3>`), vectors, generalised cross products;
//! - [`cpu`]: the run-time choice of instruction set for the hot kernels;
//! - [`error`]: the one error enum;
//! - [`geometry`]: cell grid and pair search;
//! - [`dynamics`]: material, the Hertz-Mindlin contact law;
//! - [`scene`]: a scene as the user writes it, its one validator and what it resolves
//!   to (the radius law, the container, [`PackConfig`]);
//! - [`pipeline`]: the world and its step, random sequential addition, the layer loop;
//! - `bindings` (feature `python`): the PyO3 module `granpack._core`.
#![warn(missing_docs)]

pub mod cpu;
pub mod dynamics;
pub mod error;
pub mod geometry;
pub mod math;
pub mod pipeline;
pub mod scene;

#[cfg(feature = "python")]
mod bindings;

pub use dynamics::Material;
pub use error::{Error, Result};
pub use math::{Dim, Real, Spatial, Vector};
pub use pipeline::{Contacts, PackConfig, Packer, RadiusLaw, World};
pub use scene::SimConfig;
