//! What `hooke bench accuracy` claims about stability is measured: implicit Euler's largest
//! stable step is searched like the others', and damping is not mistaken for divergence.

use crate::common::scene_model;

use hooke::accuracy::{
    Found, IMPLICIT_SEARCH_UP_TO_SECS, is_stable, search_range, search_stable_dt,
};
use hooke::integrator::Integrator;

/// Searched from the scene's dt up to at least 0.1 s, implicit Euler stays stable to one step
/// per frame (1/60 s) and beyond on hair, cloth and jello.
#[test]
fn implicit_euler_is_measured_stable_at_one_step_per_frame() {
    for name in ["hair", "cloth", "jello"] {
        let (model, dt) = scene_model(name);
        let range = search_range(Integrator::Implicit, None, dt);
        assert!(
            range.0 == dt && range.1 >= IMPLICIT_SEARCH_UP_TO_SECS,
            "{range:?}"
        );
        let found = search_stable_dt(&model, Integrator::Implicit, range, 0.5);
        assert!(
            found.dt().is_some_and(|f| f >= 1.0 / 60.0),
            "{name}: implicit Euler's largest stable dt measured {found:?}"
        );
    }
}

/// The criterion itself: forward Euler past its limit on the undamped hair diverges, while
/// implicit Euler at the same step, which loses energy, is stable.
#[test]
fn damping_is_not_divergence() {
    let (model, dt) = scene_model("hair");
    let coarse = 16.0 * dt;
    assert!(!is_stable(&model, Integrator::Euler, coarse, 0.5));
    assert!(is_stable(&model, Integrator::Implicit, coarse, 0.5));
    // A range whose top is stable reports only that the limit is at least that.
    let found = search_stable_dt(&model, Integrator::Implicit, (dt, coarse), 0.2);
    assert_eq!(found, Found::AtLeast(coarse));
}

/// A search ends on a stable step with an unstable one within 0.5% above it, starting from the
/// estimate `hooke check` gives.
#[test]
fn the_search_brackets_the_limit_tightly() {
    let (model, dt) = scene_model("hair");
    let estimate = hooke::stability::stable_dts(&model)
        .into_iter()
        .find(|(i, _)| *i == Integrator::SemiImplicit)
        .and_then(|(_, e)| e);
    let range = search_range(Integrator::SemiImplicit, estimate, dt);
    let Found::Largest(found) = search_stable_dt(&model, Integrator::SemiImplicit, range, 0.5)
    else {
        panic!("no limit found within {range:?}");
    };
    assert!(is_stable(&model, Integrator::SemiImplicit, found, 0.5));
    assert!(!is_stable(
        &model,
        Integrator::SemiImplicit,
        found * 1.005,
        0.5
    ));
}
