//! The time step, the world that owns the state, random sequential addition, the
//! layer loop, the consolidation stage and the strain-controlled drive of the element
//! tests.

pub mod consolidate;
pub mod pack;
pub mod rsa;
pub mod shear;
pub mod world;

pub use crate::scene::{DiscreteLaw, FractionsBy, SieveLaw};
pub use consolidate::{consolidate, ConsolidateConfig, ConsolidateReport, ServoCheck, ServoTarget};
pub use pack::{LayerPlacer, LayerReport, PackConfig, Packer, RadiusLaw};
pub use world::{Contacts, FreezeConfig, World};
