//! Constants of the contact between masses that both backends apply alike.

/// Share of a pair's tangential sliding that its friction may stop within one step. A contact
/// with a collider may stop a mass's sliding outright (`contact_force`), but a mass can touch
/// several others at once and each pair's friction acts on it: were each to stop the whole
/// sliding, four or more together would reverse it every step, leaving the mass jittering and
/// the ledger counting energy that never left. A quarter keeps eight simultaneous pairs from
/// overshooting; sticking then takes a few steps instead of one.
pub const PAIR_STICK_SHARE: f32 = 0.25;
