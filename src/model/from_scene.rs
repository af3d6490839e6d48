//! The model of a validated scene: its grids laid out, their springs, pins and colliders.

use glam::Vec3;

use crate::laws::spring_kind::{SpringKindTag, kind_offsets};
use crate::scene::{self, Scene};

use super::builder::ModelBuilder;
use super::colliders::{Collider, ContactModel, Effects, GroundCollider, MassContact, Path, Shape};
use super::from_mesh;
use super::springs::SpringLimits;
use super::system::{BodyShape, Model};

/// Build the model of a validated scene.
pub fn build(scene: &Scene) -> Model {
    let mut mb = ModelBuilder::new();
    let mut min_spacing = f32::INFINITY;
    for body in &scene.bodies {
        min_spacing = min_spacing.min(body.finest_spacing_m());
        let first = mb.body_spring_start();
        let shape = match &body.surface {
            Some(mesh) => from_mesh::add(&mut mb, body, mesh),
            None => {
                let grid = Grid::of(body);
                let base = mb.mass_count();
                add_masses(&mut mb, body, &grid);
                add_springs(&mut mb, body, &grid, base);
                BodyShape::Grid(body.grid.clone())
            }
        };
        // Order the body's springs by the masses they join, kinds interleaved, so that a mass's
        // springs (and its neighbours') sit close together in memory for the force passes.
        if body.plasticity.is_some() || body.tearing.is_some() {
            mb.limit_springs_from(
                first,
                SpringLimits {
                    yield_strain: body.plasticity.map_or(f32::INFINITY, |p| p.yield_strain),
                    relax: 0.0,
                    break_strain: body.tearing.map_or(f32::INFINITY, |t| t.max_strain),
                    creep_per_s: body.plasticity.map_or(0.0, |p| p.creep_per_s),
                },
            );
        }
        mb.sort_springs_from(first);
        mb.end_body(&body.name, shape);
    }
    // A fast mass may sink a little into a collider before the penalty force turns it round; the
    // post-step safeguard only acts past half a grid spacing (a quarter radius for spheres), so it
    // never fights the penalty contact in ordinary motion but stops any tunnelling.
    let skin = 0.5 * min_spacing;
    let e = &scene.effects;
    mb.effects(Effects {
        gravity_m_per_s2: e.gravity_m_per_s2.map(Vec3::from),
        air_drag_per_s: e.air_drag_per_s,
        ground: e.ground.as_ref().map(|g| GroundCollider {
            height_m: g.height_m,
            contact: ContactModel::from_scene(g.contact()),
            max_depth_m: skin,
        }),
        colliders: colliders(e, skin),
        self_collision: e.self_collision.as_ref().map(|c| MassContact {
            radius_m: c.radius_m,
            contact: ContactModel::from_scene(c.contact()),
            within_bodies: c.within_bodies,
        }),
        ..Effects::default()
    });
    mb.build()
}

/// A body's grid: its size along three axes (1 where it has fewer) and its unit axes.
struct Grid {
    dim: usize,
    n: [u32; 3],
    axes: Vec<Vec3>,
}

impl Grid {
    fn of(body: &scene::Body) -> Self {
        let dim = body.grid.len();
        let n = [
            body.grid[0],
            body.grid.get(1).copied().unwrap_or(1),
            body.grid.get(2).copied().unwrap_or(1),
        ];
        let default_axes = [Vec3::X, Vec3::Y, Vec3::Z];
        let axes: Vec<Vec3> = match &body.axes {
            Some(a) => a.iter().map(|v| Vec3::from(*v).normalize()).collect(),
            None => default_axes[..dim].to_vec(),
        };
        Self { dim, n, axes }
    }

    fn axis(&self, a: usize) -> Vec3 {
        self.axes.get(a).copied().unwrap_or(Vec3::ZERO)
    }

    /// The mass at grid point (i, j, k), counted within the body.
    fn index(&self, i: u32, j: u32, k: u32) -> u32 {
        i + self.n[0] * (j + self.n[1] * k)
    }
}

/// The body's masses, in grid order (i fastest).
fn add_masses(mb: &mut ModelBuilder, body: &scene::Body, grid: &Grid) {
    let n = grid.n;
    let count = n[0] * n[1] * n[2];
    let m = body.mass_kg / count as f32;
    let origin = Vec3::from(body.origin_m);
    let vel = Vec3::from(body.velocity_m_per_s);
    let spacing = body.spacing_m.unwrap_or_default();
    let pinned: std::collections::HashSet<u32> = body
        .pins
        .iter()
        .map(|p| {
            grid.index(
                p[0],
                p.get(1).copied().unwrap_or(0),
                p.get(2).copied().unwrap_or(0),
            )
        })
        .collect();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let p = origin
                    + spacing
                        * (i as f32 * grid.axis(0)
                            + j as f32 * grid.axis(1)
                            + k as f32 * grid.axis(2));
                let pin = pinned.contains(&grid.index(i, j, k))
                    || body.pins_in.iter().any(|r| r.contains(p));
                mb.mass(p, vel, m, pin);
            }
        }
    }
}

/// The body's springs, kind by kind and offset by offset; `base` is its first mass.
fn add_springs(mb: &mut ModelBuilder, body: &scene::Body, grid: &Grid, base: u32) {
    let n = grid.n;
    let kinds = [
        (SpringKindTag::Structural, body.springs.structural),
        (SpringKindTag::Shear, body.springs.shear),
        (SpringKindTag::Bending, body.springs.bending),
    ];
    for (tag, params) in kinds {
        let Some(params) = params else { continue };
        for off in kind_offsets(tag) {
            // Skip offsets that move along axes this grid does not have.
            if off
                .iter()
                .enumerate()
                .any(|(a, &o)| a >= grid.dim && o != 0)
            {
                continue;
            }
            // Every spring of one offset has the grid's own rest length, computed once: the
            // distance between two rounded positions would differ from spring to spring in the
            // last bits, and the GPU's stencil step (gpu/stencils.rs) reads one rest length per
            // offset, not one per spring.
            let step = off[0] as f32 * grid.axis(0)
                + off[1] as f32 * grid.axis(1)
                + off[2] as f32 * grid.axis(2);
            let rest = body.spacing_m.unwrap_or_default() * step.length();
            for k in 0..n[2] {
                for j in 0..n[1] {
                    for i in 0..n[0] {
                        let (ti, tj, tk) = (
                            i as i64 + off[0] as i64,
                            j as i64 + off[1] as i64,
                            k as i64 + off[2] as i64,
                        );
                        if ti < 0
                            || tj < 0
                            || tk < 0
                            || ti >= n[0] as i64
                            || tj >= n[1] as i64
                            || tk >= n[2] as i64
                        {
                            continue;
                        }
                        let a = base + grid.index(i, j, k);
                        let b = base + grid.index(ti as u32, tj as u32, tk as u32);
                        mb.spring_with_rest(
                            a,
                            b,
                            rest,
                            params.stiffness_n_per_m,
                            params.damping_n_s_per_m,
                            tag,
                        );
                    }
                }
            }
        }
    }
}

fn path_of(center_m: Option<[f32; 3]>, velocity: [f32; 3], keys: &[scene::Keyframe]) -> Path {
    if keys.is_empty() {
        Path::Linear {
            start_m: Vec3::from(center_m.unwrap_or_default()),
            velocity_m_per_s: Vec3::from(velocity),
        }
    } else {
        Path::Keyframes(
            keys.iter()
                .map(|k| (k.time_secs, Vec3::from(k.center_m)))
                .collect(),
        )
    }
}

/// The scene's colliders; `skin` is the largest safeguard depth (half the finest grid spacing).
fn colliders(e: &scene::Effects, skin: f32) -> Vec<Collider> {
    let spheres = e.spheres.iter().map(|s| Collider {
        shape: Shape::Sphere {
            radius_m: s.radius_m,
        },
        path: path_of(s.center_m, s.velocity_m_per_s, &s.keyframes),
        contact: ContactModel::from_scene(s.contact()),
        max_depth_m: skin.min(0.25 * s.radius_m),
    });
    let boxes = e.boxes.iter().map(|b| {
        let h = Vec3::from(b.half_extents_m);
        Collider {
            shape: Shape::Box { half_extents_m: h },
            path: path_of(b.center_m, b.velocity_m_per_s, &b.keyframes),
            contact: ContactModel::from_scene(b.contact()),
            max_depth_m: skin.min(0.25 * h.min_element()),
        }
    });
    let planes = e.planes.iter().map(|p| Collider {
        shape: Shape::Plane {
            normal: Vec3::from(p.normal).normalize(),
        },
        path: Path::Linear {
            start_m: Vec3::from(p.point_m),
            velocity_m_per_s: Vec3::ZERO,
        },
        contact: ContactModel::from_scene(p.contact()),
        max_depth_m: skin,
    });
    spheres.chain(boxes).chain(planes).collect()
}
