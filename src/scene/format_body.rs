//! The scene file's bodies: a grid or a mesh, its pins, its springs and what lets them yield or
//! tear. `deny_unknown_fields`, SI units in the field names, as in `format.rs`.

use serde::{Deserialize, Serialize};

/// A body: a grid of masses — 1D (strand), 2D (sheet) or 3D (block) — or a triangle mesh from
/// a file (`mesh`), cloth from an open surface or, with `fill = "lattice"`, a soft body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Body {
    pub name: String,
    /// Masses along each grid axis: `[n]`, `[nu, nv]` or `[nu, nv, nw]` (a grid body).
    #[serde(default)]
    pub grid: Vec<u32>,
    /// An OBJ, glTF or GLB file, relative to the scene file's folder (a mesh body).
    #[serde(default)]
    pub mesh: Option<String>,
    /// Distance between grid neighbours at rest (a grid body, or a mesh's lattice).
    #[serde(default)]
    pub spacing_m: Option<f32>,
    /// Total mass of the body: shared equally by a grid's masses, by triangle area on a mesh.
    pub mass_kg: f32,
    /// World position of grid index `[0, 0, 0]`, or of the mesh's own origin.
    #[serde(default)]
    pub origin_m: [f32; 3],
    /// World direction of each grid axis (normalised); defaults to x, y, z in turn.
    #[serde(default)]
    pub axes: Option<Vec<[f32; 3]>>,
    /// A mesh's size factor: its file's units times `scale` are metres.
    #[serde(default = "default_scale")]
    pub scale: f32,
    /// A mesh's rotation: about x, then y, then z (fixed world axes), in degrees.
    #[serde(default)]
    pub rotation_deg: [f32; 3],
    /// What a mesh's inside becomes: nothing (`"none"`: cloth or a shell) or a jello lattice at
    /// `spacing_m` that carries the surface (`"lattice"`, a closed surface only).
    #[serde(default)]
    pub fill: Fill,
    /// Initial velocity of every mass.
    #[serde(default)]
    pub velocity_m_per_s: [f32; 3],
    /// Masses held fixed in place: grid indices (`[i, j]`), or a mesh's vertex indices (`[v]`,
    /// or `v` alone: `pins = [0, 10]`).
    #[serde(default, deserialize_with = "pin_list")]
    pub pins: Vec<Vec<u32>>,
    /// Every mass that starts inside these regions is pinned.
    #[serde(default, deserialize_with = "one_or_many")]
    pub pins_in: Vec<PinRegion>,
    /// A mesh's named vertex groups (OBJ groups or objects, glTF nodes) whose vertices are pinned.
    #[serde(default)]
    pub pin_groups: Vec<String>,
    #[serde(default)]
    pub springs: Springs,
    /// Springs stretched or squeezed past a yield strain creep toward their current length.
    #[serde(default)]
    pub plasticity: Option<Plasticity>,
    /// Springs stretched past a limit break for good.
    #[serde(default)]
    pub tearing: Option<Tearing>,
    /// The mesh read from `mesh` when the scene was loaded (never written to a file).
    #[serde(skip)]
    pub surface: Option<std::sync::Arc<crate::mesh::TriMesh>>,
}

impl Body {
    /// Where a mesh's file point `p` starts in the world: scaled, rotated, then moved to
    /// `origin_m`.
    pub fn place(&self, p: glam::Vec3) -> glam::Vec3 {
        let [x, y, z] = self.rotation_deg.map(f32::to_radians);
        let r = glam::Quat::from_rotation_z(z)
            * glam::Quat::from_rotation_y(y)
            * glam::Quat::from_rotation_x(x);
        glam::Vec3::from(self.origin_m) + r * (self.scale * p)
    }

    /// The mesh's vertices where they start in the world (empty for a grid body).
    pub fn placed_vertices(&self) -> Vec<glam::Vec3> {
        self.surface
            .as_ref()
            .map(|m| m.positions.iter().map(|&p| self.place(p)).collect())
            .unwrap_or_default()
    }

    /// The shortest distance between neighbouring masses at rest: a grid's or a lattice's
    /// spacing, a mesh cloth's shortest edge.
    pub fn finest_spacing_m(&self) -> f32 {
        match (&self.surface, self.fill) {
            (Some(m), Fill::None) => {
                let x = self.placed_vertices();
                m.triangles
                    .iter()
                    .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
                    .map(|(a, b)| x[a as usize].distance(x[b as usize]))
                    .fold(f32::INFINITY, f32::min)
            }
            _ => self.spacing_m.unwrap_or(f32::INFINITY),
        }
    }

    /// How many masses the body has (for a lattice, at most: the cells of its bounding box).
    pub fn mass_count_bound(&self) -> u64 {
        match (&self.surface, self.fill) {
            (None, _) => self.grid.iter().map(|&n| u64::from(n)).product(),
            (Some(m), Fill::None) => m.positions.len() as u64,
            (Some(_), Fill::Lattice) => {
                let x = self.placed_vertices();
                let (lo, hi) = x.iter().fold(
                    (glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY),
                    |(lo, hi), p| (lo.min(*p), hi.max(*p)),
                );
                let spacing = self.spacing_m.unwrap_or(f32::INFINITY);
                crate::mesh::cells_for(hi - lo, spacing)
                    .iter()
                    .map(|c| c.saturating_add(1))
                    .fold(1u64, u64::saturating_mul)
            }
        }
    }
}

fn default_scale() -> f32 {
    1.0
}

/// What fills a mesh body's inside.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Fill {
    /// The surface alone: cloth, or a closed shell (a balloon without pressure).
    #[default]
    None,
    /// A jello lattice at `spacing_m`; the surface's vertices follow its cells.
    Lattice,
}

/// A region of space, a box (`min_m`, `max_m`) or a ball (`center_m`, `radius_m`): every mass
/// starting inside is pinned.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinRegion {
    #[serde(default)]
    pub min_m: Option<[f32; 3]>,
    #[serde(default)]
    pub max_m: Option<[f32; 3]>,
    #[serde(default)]
    pub center_m: Option<[f32; 3]>,
    #[serde(default)]
    pub radius_m: Option<f32>,
}

impl PinRegion {
    /// Whether `p` lies inside (boundary included). A region that validation refused holds
    /// nothing.
    pub fn contains(&self, p: glam::Vec3) -> bool {
        match (self.min_m, self.max_m, self.center_m, self.radius_m) {
            (Some(lo), Some(hi), None, None) => {
                p.cmpge(glam::Vec3::from(lo)).all() && p.cmple(glam::Vec3::from(hi)).all()
            }
            (None, None, Some(c), Some(r)) => p.distance(glam::Vec3::from(c)) <= r,
            _ => false,
        }
    }
}

/// `pins = [[i, j], …]`, and for a mesh's vertices `pins = [v, …]` too (each `v` read as `[v]`).
fn pin_list<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<Vec<u32>>, D::Error> {
    struct Pins;
    impl<'de> serde::de::Visitor<'de> for Pins {
        type Value = Vec<Vec<u32>>;
        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str(
                "a list of pins, each a grid index (`[i, j]`) or a mesh vertex (`v` or `[v]`)",
            )
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(
            self,
            mut seq: A,
        ) -> Result<Self::Value, A::Error> {
            #[derive(Deserialize)]
            #[serde(
                untagged,
                expecting = "a pin: a grid index (`[i, j]`) or a mesh vertex (`v` or `[v]`), each a whole number from 0"
            )]
            enum Pin {
                Vertex(u32),
                Index(Vec<u32>),
            }
            let mut pins = Vec::new();
            while let Some(pin) = seq.next_element::<Pin>()? {
                pins.push(match pin {
                    Pin::Vertex(v) => vec![v],
                    Pin::Index(i) => i,
                });
            }
            Ok(pins)
        }
    }
    d.deserialize_seq(Pins)
}

/// `pins_in = { … }` or `pins_in = [{ … }, { … }]`.
fn one_or_many<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<PinRegion>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum OneOrMany {
        One(PinRegion),
        Many(Vec<PinRegion>),
    }
    Ok(match OneOrMany::deserialize(d)? {
        OneOrMany::One(r) => vec![r],
        OneOrMany::Many(v) => v,
    })
}

/// Plastic flow of a body's springs: past `yield_strain`, a spring's rest length relaxes toward
/// the length at which its strain would be exactly `±yield_strain`, at rate `creep_per_s`
/// (rest length `r` follows dr/dt = creep_per_s · (r* − r)). The elastic energy it lets go is
/// dissipated (the ledger's plastic term).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plasticity {
    /// |strain| below which a spring stays elastic, e.g. 0.05.
    pub yield_strain: f32,
    /// How fast the rest length follows past yield (1/s); large values make flow instantaneous.
    pub creep_per_s: f32,
}

/// Tearing: a spring whose strain exceeds `max_strain` breaks. A broken spring exerts no force,
/// is no longer drawn, and never heals; its elastic energy at the break is dissipated.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tearing {
    /// Strain (|x| − L) / L at which a spring breaks, e.g. 0.3.
    pub max_strain: f32,
}

/// Which spring kinds the body has. Absent kinds are not built.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Springs {
    /// Nearest grid neighbours along each axis.
    #[serde(default)]
    pub structural: Option<SpringKind>,
    /// Diagonal neighbours (face diagonals, and body diagonals in 3D).
    #[serde(default)]
    pub shear: Option<SpringKind>,
    /// Second neighbours along each axis: resist folding.
    #[serde(default)]
    pub bending: Option<SpringKind>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringKind {
    pub stiffness_n_per_m: f32,
    /// Damping along the spring: force `-c (v_rel · x̂)`.
    #[serde(default)]
    pub damping_n_s_per_m: f32,
}
