//! Extended position-based dynamics for the springs (Macklin, Müller & Chentanez 2016, "XPBD"),
//! in the many-substeps form of "Small Steps in Physics Simulation" (Macklin et al. 2019).
//!
//! Each spring is a distance constraint C = |x_a − x_b| − L with compliance α = 1/k and the
//! paper's constraint damping β = c (the spring's dashpot, N·s/m), so that in the limit of small
//! substeps a constraint pulls with k·C and damps with c·(n · v_ab), like the Hooke spring it
//! replaces. One substep of length h:
//!
//! 1. `v += h · a_ext(x, v, t)` for everything that is not a spring (gravity, drag, contact,
//!    colliders), then the predicted displacement `dx = h · v`;
//! 2. per iteration, per colour, per spring of that colour: `xpbd_solve_spring` corrects `dx`;
//! 3. `v = dx / h`, `x += dx`.
//!
//! The solve works on the displacement `dx`, not on positions: a substep moves a mass by far
//! less than one f32 unit of its position (h² g = 1e-7 m at h = 0.1 ms, the spacing of f32 near
//! 1 m), so `v = (x_new − x_old) / h` would be mostly round-off. `dx` keeps its own precision,
//! and a spring's vector is formed as `(x_a − x_b) + (dx_a − dx_b)`, exact to the spring's scale.
//!
//! Springs are solved by graph-coloured Gauss–Seidel: the springs of one colour share no movable
//! mass, so they can be solved at once, in any order, with the same result on every thread and on
//! the GPU. Plain Jacobi would be order-free too but, averaged to stay stable, it converges to the
//! wrong stiffness with one iteration per substep; colouring keeps XPBD's own fixed point.

use glam::Vec3;

use crate::backend::StopFlags;
use crate::model::Spring;
use crate::physics::{Colouring, XpbdSpring, colour_springs, xpbd_constants};

/// One constraint projection of spring `s` (XPBD, eq. 26 of the 2016 paper): corrects the
/// displacements `dx` of its two masses along the spring and returns the multiplier's increment
/// Δλ. `x` holds the positions at the start of the substep; `lambda` is the spring's multiplier
/// so far in this substep. Nothing moves for a broken or zero-length spring, or when both masses
/// are pinned.
#[inline(always)]
pub fn xpbd_solve_spring(
    s: &Spring,
    k: XpbdSpring,
    inv_mass: &[f32],
    x: &[Vec3],
    dx: &mut [Vec3],
    lambda: f32,
) -> f32 {
    let (a, b) = (s.a as usize, s.b as usize);
    let (wa, wb) = (inv_mass[a], inv_mass[b]);
    let w = wa + wb;
    if s.is_broken() || w == 0.0 || k.alpha_tilde == 0.0 {
        return 0.0;
    }
    // Relative motion since the start of the substep: the damping term's argument.
    let moved = dx[a] - dx[b];
    let d = (x[a] - x[b]) + moved;
    let len = d.length();
    // As `spring_force`: a spring this short has no direction.
    if len <= f32::MIN_POSITIVE * 1e6 {
        return 0.0;
    }
    // One division, not three, as on the GPU.
    let n = d * (1.0 / len);
    let c = len - s.rest_m;
    let numerator = -c - k.alpha_tilde * lambda - k.gamma * n.dot(moved);
    let denominator = (1.0 + k.gamma) * w + k.alpha_tilde;
    let dl = numerator / denominator;
    // A pinned end is never written (as on the GPU, where springs of one colour may share it).
    if wa > 0.0 {
        dx[a] += (wa * dl) * n;
    }
    if wb > 0.0 {
        dx[b] -= (wb * dl) * n;
    }
    dl
}

/// Step 2 of a substep: `iterations` sweeps over the colours (fewer once `stop` is asked),
/// correcting `dx`. `lambda` (one per spring) is reset here.
#[allow(clippy::too_many_arguments)]
pub fn xpbd_solve(
    springs: &[Spring],
    constants: &[XpbdSpring],
    colouring: &Colouring,
    inv_mass: &[f32],
    iterations: u32,
    x: &[Vec3],
    dx: &mut [Vec3],
    lambda: &mut [f32],
    stop: &StopFlags,
) {
    lambda.iter_mut().for_each(|l| *l = 0.0);
    for _ in 0..iterations {
        if stop.asked() {
            break;
        }
        for c in 0..colouring.colours() {
            for &i in colouring.springs_of(c) {
                let i = i as usize;
                lambda[i] +=
                    xpbd_solve_spring(&springs[i], constants[i], inv_mass, x, dx, lambda[i]);
            }
        }
    }
}

/// Step 3 of a substep: the velocity the masses moved with, `dx / h`, and their new positions.
/// A pinned mass has no velocity and no correction, so its dx is zero and it stays.
pub fn xpbd_update_velocity(dx: &[Vec3], h: f32, x: &mut [Vec3], v: &mut [Vec3]) {
    for ((x, v), dx) in x.iter_mut().zip(v.iter_mut()).zip(dx) {
        *v = *dx / h;
        *x += *dx;
    }
}

/// What an XPBD run keeps between substeps: the colouring, each spring's constants for the
/// substep length, and the displacement and multiplier buffers.
#[derive(Debug, Clone)]
pub struct XpbdWork {
    pub colouring: Colouring,
    pub constants: Vec<XpbdSpring>,
    pub iterations: u32,
    /// The substep's displacement: `xpbd_predict` (src/cpu/integrate.rs) fills it.
    pub dx: Vec<Vec3>,
    lambda: Vec<f32>,
}

impl XpbdWork {
    pub fn new(springs: &[Spring], inv_mass: &[f32], h_secs: f64, iterations: u32) -> Self {
        Self {
            colouring: colour_springs(springs, inv_mass),
            constants: xpbd_constants(springs, h_secs),
            iterations,
            dx: vec![Vec3::ZERO; inv_mass.len()],
            lambda: vec![0.0; springs.len()],
        }
    }

    /// Steps 2 and 3 of a substep, once `dx` holds the prediction: project the springs, then
    /// take the velocities and positions. `springs` are the springs as they are now
    /// (plasticity and tearing change them).
    pub fn project(
        &mut self,
        springs: &[Spring],
        inv_mass: &[f32],
        h: f32,
        (x, v): (&mut [Vec3], &mut [Vec3]),
        stop: &StopFlags,
    ) {
        xpbd_solve(
            springs,
            &self.constants,
            &self.colouring,
            inv_mass,
            self.iterations,
            x,
            &mut self.dx,
            &mut self.lambda,
            stop,
        );
        xpbd_update_velocity(&self.dx, h, x, v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Energy the springs' dashpots dissipate over a substep of `h` at state (x, v):
    /// h Σ c (n · v_ab)², the power XPBD's damping term applies in the limit of small substeps. The
    /// backends book it at each substep's start (as `compute_forces`' damping rate); what XPBD loses
    /// beyond it is its own numerical dissipation, which the energy balance shows.
    fn xpbd_damping_energy(springs: &[Spring], x: &[Vec3], v: &[Vec3], h: f64) -> f64 {
        springs
            .iter()
            .filter(|s| !s.is_broken() && s.damping_n_s_per_m > 0.0)
            .map(|s| {
                let (a, b) = (s.a as usize, s.b as usize);
                let d = x[a] - x[b];
                let len = d.length();
                if len == 0.0 {
                    return 0.0;
                }
                let rate = f64::from((d / len).dot(v[a] - v[b]));
                f64::from(s.damping_n_s_per_m) * rate * rate * h
            })
            .sum()
    }

    fn spring(a: u32, b: u32, rest: f32, k: f32, c: f32) -> Spring {
        Spring {
            a,
            b,
            rest_m: rest,
            stiffness_n_per_m: k,
            damping_n_s_per_m: c,
        }
    }

    /// A chain of `n` springs hanging from a pinned top mass, at rest length.
    fn chain(n: usize, k: f32, c: f32) -> (Vec<Spring>, Vec<f32>, Vec<Vec3>) {
        let springs = (0..n as u32).map(|i| spring(i, i + 1, 0.1, k, c)).collect();
        let mut inv_mass = vec![1.0 / 0.01; n + 1];
        inv_mass[0] = 0.0;
        let x = (0..=n)
            .map(|i| Vec3::new(0.0, -0.1 * i as f32, 0.0))
            .collect();
        (springs, inv_mass, x)
    }

    #[test]
    fn no_two_springs_of_a_colour_share_a_movable_mass_and_every_spring_is_coloured() {
        // A 6 × 6 sheet with structural, shear and bending springs, one corner pinned.
        let n = 6u32;
        let id = |i: u32, j: u32| i * n + j;
        let mut springs = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for (di, dj) in [(0, 1), (1, 0), (1, 1), (1, -1i32), (0, 2), (2, 0)] {
                    let (a, b) = (i + di, j as i32 + dj);
                    if a < n && b >= 0 && (b as u32) < n {
                        springs.push(spring(id(i, j), id(a, b as u32), 0.1, 100.0, 0.0));
                    }
                }
            }
        }
        let mut inv_mass = vec![1.0; (n * n) as usize];
        inv_mass[0] = 0.0;
        let col = colour_springs(&springs, &inv_mass);
        assert_eq!(col.order.len(), springs.len());
        let mut seen = vec![false; springs.len()];
        for c in 0..col.colours() {
            let mut masses = std::collections::HashSet::new();
            for &s in col.springs_of(c) {
                assert!(!seen[s as usize], "spring {s} twice");
                seen[s as usize] = true;
                for m in [springs[s as usize].a, springs[s as usize].b] {
                    if inv_mass[m as usize] > 0.0 {
                        assert!(masses.insert(m), "colour {c}: mass {m} twice");
                    }
                }
            }
        }
        // Greedy edge colouring needs at most 2Δ − 1 colours (Δ = 12 springs at a mass here).
        assert!(col.colours() <= 23, "{} colours", col.colours());
    }

    /// A damped chain of 8 springs released at rest length under gravity and run for 10 s in
    /// substeps of `h`: each spring's stretch over the analytic static stretch (n − i) m g / k,
    /// the energy the dashpots let go, and the energy the chain lost.
    fn settle_chain(h: f32) -> (Vec<f32>, f64, f64) {
        let (n, k, c, g, m) = (8usize, 400.0f32, 0.5f32, 9.81f32, 0.01f32);
        let (springs, inv_mass, mut x) = chain(n, k, c);
        let mut work = XpbdWork::new(&springs, &inv_mass, f64::from(h), 1);
        let mut v = vec![Vec3::ZERO; n + 1];
        let energy = |x: &[Vec3], v: &[Vec3]| -> f64 {
            let kinetic: f64 = v
                .iter()
                .map(|v| 0.5 * f64::from(m) * f64::from(v.length_squared()))
                .sum();
            let gravity: f64 = x.iter().skip(1).map(|x| f64::from(m * g * x.y)).sum();
            let elastic: f64 = springs
                .iter()
                .map(|s| {
                    let e = f64::from((x[s.a as usize] - x[s.b as usize]).length() - s.rest_m);
                    0.5 * f64::from(k) * e * e
                })
                .sum();
            kinetic + gravity + elastic
        };
        let e0 = energy(&x, &v);
        let mut damped = 0.0;
        for _ in 0..(10.0 / h).round() as u32 {
            damped += xpbd_damping_energy(&springs, &x, &v, f64::from(h));
            for v in &mut v[1..] {
                v.y -= h * g;
            }
            for (dx, v) in work.dx.iter_mut().zip(&v) {
                *dx = h * *v;
            }
            work.project(
                &springs,
                &inv_mass,
                h,
                (&mut x, &mut v),
                &StopFlags::default(),
            );
        }
        let stretch = (0..n)
            .map(|i| ((x[i] - x[i + 1]).length() - 0.1) / ((n - i) as f32 * m * g / k))
            .collect();
        (stretch, damped, e0 - energy(&x, &v))
    }

    #[test]
    fn a_hanging_chain_settles_at_the_analytic_static_stretch() {
        // Coloured Gauss–Seidel with one iteration leaves the springs solved first a little
        // longer, by a share that falls with h (18% at h = 1 ms here, 3.7% at 0.3 ms, 1.1% at
        // 0.1 ms): substeps small enough make it vanish, as "Small Steps" promises.
        let (stretch, damped, lost) = settle_chain(5.0e-5);
        for (i, r) in stretch.iter().enumerate() {
            assert!(
                (r - 1.0).abs() < 0.01,
                "spring {i}: {r} × the analytic stretch"
            );
        }
        // The dashpots account for the energy lost, but for XPBD's own numerical damping.
        assert!(
            (damped - lost).abs() < 0.05 * lost,
            "the dashpots let go {damped} J of the {lost} J the chain lost"
        );
    }

    #[test]
    fn xpbd_numerical_damping_falls_with_the_substep() {
        let unbooked = |h: f32| {
            let (_, damped, lost) = settle_chain(h);
            (lost - damped) / lost
        };
        let (coarse, fine) = (unbooked(2.0e-4), unbooked(5.0e-5));
        assert!(
            fine > 0.0 && coarse > 2.0 * fine,
            "{coarse} at 0.2 ms, {fine} at 0.05 ms"
        );
    }

    /// One mass on a damped spring from a pinned anchor, released stretched: XPBD's position
    /// error against the analytic solution falls about in proportion to the substep.
    #[test]
    fn a_damped_oscillator_converges_to_the_analytic_solution_as_substeps_shrink() {
        let (k, c, m, rest, stretch) = (100.0f64, 0.2f64, 0.05f64, 0.1f64, 0.01f64);
        let springs = [spring(0, 1, rest as f32, k as f32, c as f32)];
        let inv_mass = [0.0, (1.0 / m) as f32];
        let omega0 = (k / m).sqrt();
        let zeta = c / (2.0 * (k * m).sqrt());
        let omega_d = omega0 * (1.0 - zeta * zeta).sqrt();
        let t_end = 0.5f64;
        // u(t) = e^{−ζω₀t} (u₀ cos ω_d t + (ζω₀u₀/ω_d) sin ω_d t), released at rest.
        let analytic = |t: f64| {
            (-zeta * omega0 * t).exp()
                * stretch
                * ((omega_d * t).cos() + zeta * omega0 / omega_d * (omega_d * t).sin())
        };
        let col = colour_springs(&springs, &inv_mass);
        let error = |steps: u32| {
            let h = t_end / f64::from(steps);
            let constants = xpbd_constants(&springs, h);
            let mut x = vec![Vec3::ZERO, Vec3::new((rest + stretch) as f32, 0.0, 0.0)];
            let (mut v, mut dx, mut lambda) = (vec![Vec3::ZERO; 2], vec![Vec3::ZERO; 2], [0.0]);
            for _ in 0..steps {
                dx[1] = h as f32 * v[1];
                xpbd_solve(
                    &springs,
                    &constants,
                    &col,
                    &inv_mass,
                    1,
                    &x,
                    &mut dx,
                    &mut lambda,
                    &StopFlags::default(),
                );
                xpbd_update_velocity(&dx, h as f32, &mut x, &mut v);
            }
            (f64::from(x[1].x) - rest - analytic(t_end)).abs()
        };
        let errors: Vec<f64> = [250, 500, 1000, 2000].into_iter().map(error).collect();
        for w in errors.windows(2) {
            let ratio = w[0] / w[1];
            assert!(
                (1.6..2.6).contains(&ratio),
                "halving the substep divides the error by {ratio} (errors {errors:?})"
            );
        }
    }
}
