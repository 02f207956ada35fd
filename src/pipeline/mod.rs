//! The time step, the world that owns the state, the radius laws, random sequential
//! addition and the layer loop.

pub mod consolidate;
pub mod pack;
pub mod rsa;
pub mod sizes;
pub mod world;

pub use consolidate::{consolidate, ConsolidateConfig, ConsolidateReport, ServoCheck, ServoTarget};
pub use pack::{LayerReport, PackConfig, Packer, RadiusLaw};
pub use sizes::{DiscreteLaw, FractionsBy, SieveLaw};
pub use world::{Contacts, Container, FreezeConfig, Inertia2D, SimConfig, World};
