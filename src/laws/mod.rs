//! The laws every layer computes from and names: a contact's penalty law, and the kinds of
//! spring a body has. They import nothing of the crate, so the scene, the model and both
//! backends can share them.

pub mod contact_law;
pub mod spring_kind;
