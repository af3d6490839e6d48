//! Constants of the contact between masses that both backends apply alike.

/// Share of a pair's tangential sliding that its friction may stop within one step. A contact
/// with a collider may stop a mass's sliding outright (`contact_force`), but a mass can touch
/// several others at once and each pair's friction acts on it: were each to stop the whole
/// sliding, four or more together would reverse it every step, leaving the mass jittering and
/// the ledger counting energy that never left. A quarter keeps eight simultaneous pairs from
/// overshooting; sticking then takes a few steps instead of one.
pub const PAIR_STICK_SHARE: f32 = 0.25;

/// The neighbour lists' skin as a share of the contact radius. A mass's list holds every mass
/// within `2 r + skin` of it when the lists were built, so it stays complete (holds every mass
/// it can touch) until some mass has moved half the skin. A wider skin rebuilds less often and
/// visits more candidates each evaluation.
pub const NEIGHBOUR_SKIN_SHARE: f32 = 1.0;

/// How far a mass may move from where the lists were built before they are rebuilt: 60% of half
/// the skin, so that every pair within [`pair_onset_sq_m2`]'s distance stays listed (two masses
/// close by at most 0.6 of the skin, which leaves 0.35 of it and a margin for the f32 rounding
/// of the distances tested at the build).
const MOVED_SHARE_OF_HALF_SKIN: f32 = 0.6;

/// How far into the skin, as a share of it, a closing pair's contact may act before the touch
/// (`cpu::law::contact_normal_force` damps a fast approach there).
const ONSET_SHARE_OF_SKIN: f32 = 0.35;

/// Distance within which the lists take a pair, `2 r + skin`; also the cell of the grid they
/// are built with, so that such a pair lies in the same or neighbouring cells.
pub fn neighbour_reach_m(radius_m: f32) -> f32 {
    (2.0 + NEIGHBOUR_SKIN_SHARE) * radius_m
}

/// The displacement since the last build past which a mass makes the lists stale.
pub fn neighbour_moved_limit_m(radius_m: f32) -> f32 {
    MOVED_SHARE_OF_HALF_SKIN * 0.5 * NEIGHBOUR_SKIN_SHARE * radius_m
}

/// The squared distance within which a pair's contact may act, `(2 r + 0.35 skin)²`: closing fast,
/// it is damped before the touch (`cpu::law::contact_normal_force`), and every pair that near
/// is in the lists until they are rebuilt, so both backends, whichever lists or grid cells
/// they walk, find the same pairs. A pair closing faster than k (0.35 skin) / c, whose damping
/// would start farther out, starts it there and bounces a little more than its restitution says
/// (the pile's pairs would have to close at about 5 m/s; they meet at 4 at most). The shaders'
/// `PAIR_ONSET_SQ` override.
pub fn pair_onset_sq_m2(radius_m: f32) -> f32 {
    let onset = (2.0 + ONSET_SHARE_OF_SKIN * NEIGHBOUR_SKIN_SHARE) * radius_m;
    onset * onset
}
