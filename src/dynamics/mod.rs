//! Particles, material, the contact law and the integrator state.

pub mod batched_law;
pub mod contact_law;
pub mod material;

pub use contact_law::{hertz_mindlin, hertz_mindlin_coefs, ContactForce, LawCoefs, PairParams};
pub use material::Material;
