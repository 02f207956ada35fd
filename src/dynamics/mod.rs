//! Particles, material, the contact law and the integrator state.

pub mod contact_law;
pub mod material;

pub use contact_law::{hertz_mindlin, ContactForce, PairParams};
pub use material::Material;
