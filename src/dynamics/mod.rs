//! Particles, material, the contact law and the integrator state.

pub mod batched_law;
// The step loop imports the batched law by its former name, `dynamics::block`.
pub use batched_law as block;
pub mod contact_law;
pub mod material;

pub use contact_law::{hertz_mindlin, hertz_mindlin_coefs, ContactForce, LawCoefs, PairParams};
pub use material::Material;
