//! Writes the meshes the built-in mesh scenes use, under `examples/meshes/`, made here by code:
//! a flag (OBJ, quads, its hoist strip a group of its own), a tablecloth (GLB, an irregular
//! triangulation) and a bunny-like blob (OBJ, a closed surface). With `--irregular-cloth N PATH`
//! it writes instead an irregular cloth of about N triangles, for the mesh benchmark
//! (BENCHMARKS.md).
//!
//! ```text
//! cargo run --release --example make_meshes                      # the shipped meshes
//! cargo run --release --example make_meshes -- --irregular-cloth 100000 /tmp/cloth-100k.obj
//! ```

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use glam::Vec3;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [flag, n, path] = args.as_slice()
        && flag == "--irregular-cloth"
    {
        let triangles: usize = n.parse()?;
        // A square of side 1 m with about `triangles` triangles: 2 per cell.
        let cells = ((triangles as f64 / 2.0).sqrt().round() as usize).max(1);
        let (p, t) = irregular_sheet(cells, 1.0, 7);
        std::fs::write(path, obj(&p, &[("cloth", faces3(&t))]))?;
        println!("{path}: {} vertices, {} triangles", p.len(), t.len());
        return Ok(());
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/meshes");
    std::fs::create_dir_all(&dir)?;
    let (p, hoist, fly) = flag(24, 16, 1.2, 0.8);
    std::fs::write(
        dir.join("flag.obj"),
        obj(&p, &[("hoist", hoist), ("fly", fly)]),
    )?;
    let (p, t) = irregular_sheet(36, 1.6, 1);
    std::fs::write(dir.join("tablecloth.glb"), glb(&p, &t, "tablecloth"))?;
    let (p, t) = blob(3);
    std::fs::write(dir.join("blob.obj"), obj(&p, &[("blob", faces3(&t))]))?;
    println!(
        "wrote flag.obj, tablecloth.glb and blob.obj to {}",
        dir.display()
    );
    Ok(())
}

/// A flag in the xy plane, hoist along x = 0, as quads: the first column of quads (the sleeve
/// round the pole) is the group `hoist`, the rest `fly`.
fn flag(
    nu: usize,
    nv: usize,
    width: f32,
    height: f32,
) -> (Vec<Vec3>, Vec<Vec<u32>>, Vec<Vec<u32>>) {
    let mut p = Vec::new();
    for j in 0..=nv {
        for i in 0..=nu {
            p.push(Vec3::new(
                width * i as f32 / nu as f32,
                height * j as f32 / nv as f32,
                0.0,
            ));
        }
    }
    let at = |i: usize, j: usize| (i + (nu + 1) * j) as u32;
    let (mut hoist, mut fly) = (Vec::new(), Vec::new());
    for j in 0..nv {
        for i in 0..nu {
            let q = vec![at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            if i == 0 { hoist.push(q) } else { fly.push(q) }
        }
    }
    (p, hoist, fly)
}

/// A square sheet in the xz plane centred on the origin, `cells` a side, its inner vertices
/// moved by up to a fifth of a cell (never a sliver) and each cell split along a diagonal chosen at random: an
/// irregular triangulation, vertices numbered in random order.
fn irregular_sheet(cells: usize, side: f32, seed: u64) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let h = side / cells as f32;
    let n = cells + 1;
    let mut p = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let inner = i > 0 && j > 0 && i < cells && j < cells;
            let (dx, dz) = if inner {
                (rng.unit() - 0.5, rng.unit() - 0.5)
            } else {
                (0.0, 0.0)
            };
            p.push(Vec3::new(
                (i as f32 + 0.4 * dx) * h - 0.5 * side,
                0.0,
                (j as f32 + 0.4 * dz) * h - 0.5 * side,
            ));
        }
    }
    let at = |i: usize, j: usize| (i + n * j) as u32;
    let mut t = Vec::with_capacity(2 * cells * cells);
    for j in 0..cells {
        for i in 0..cells {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            // Counter-clockwise seen from +y.
            if rng.unit() < 0.5 {
                t.push([a, c, b]);
                t.push([a, d, c]);
            } else {
                t.push([a, d, b]);
                t.push([b, d, c]);
            }
        }
    }
    // Shuffle the vertex numbering: the reader must not depend on a grid's order.
    let mut perm: Vec<u32> = (0..p.len() as u32).collect();
    for k in (1..perm.len()).rev() {
        let r = (rng.next() % (k as u64 + 1)) as usize;
        perm.swap(k, r);
    }
    let mut q = vec![Vec3::ZERO; p.len()];
    for (old, &new) in perm.iter().enumerate() {
        q[new as usize] = p[old];
    }
    let t = t
        .into_iter()
        .map(|tri| tri.map(|v| perm[v as usize]))
        .collect();
    (q, t)
}

/// A bunny-like blob: a subdivided icosahedron, squashed, with two ears and a tail pushed out.
fn blob(subdivisions: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (mut p, t) = icosphere(subdivisions);
    let bumps = [
        (Vec3::new(0.3, 0.9, 0.45).normalize(), 0.9, 0.04),
        (Vec3::new(0.3, 0.9, -0.45).normalize(), 0.9, 0.04),
        (Vec3::new(-1.0, 0.2, 0.0).normalize(), 0.2, 0.05),
    ];
    for v in &mut p {
        let d = *v;
        let mut r = 1.0;
        for (dir, height, width) in bumps {
            let ang2 = 2.0 * (1.0 - d.dot(dir));
            r += height * (-ang2 / (2.0 * width)).exp();
        }
        *v = d * r * Vec3::new(0.25, 0.2, 0.2);
    }
    (p, t)
}

fn icosphere(subdivisions: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let g = (1.0 + 5f32.sqrt()) / 2.0;
    let mut p: Vec<Vec3> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut t: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut split = |a: u32, b: u32, p: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                p.push((p[a as usize] + p[b as usize]).normalize());
                p.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(4 * t.len());
        for [a, b, c] in t {
            let (ab, bc, ca) = (
                split(a, b, &mut p),
                split(b, c, &mut p),
                split(c, a, &mut p),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        t = next;
    }
    (p, t)
}

fn faces3(t: &[[u32; 3]]) -> Vec<Vec<u32>> {
    t.iter().map(|f| f.to_vec()).collect()
}

/// OBJ text: the vertices, then each group's faces (1-based indices).
fn obj(p: &[Vec3], groups: &[(&str, Vec<Vec<u32>>)]) -> String {
    let mut s = String::from("# made by examples/make_meshes.rs\n");
    for v in p {
        let _ = writeln!(s, "v {} {} {}", v.x, v.y, v.z);
    }
    for (name, faces) in groups {
        let _ = writeln!(s, "g {name}");
        for f in faces {
            s.push('f');
            for v in f {
                let _ = write!(s, " {}", v + 1);
            }
            s.push('\n');
        }
    }
    s
}

/// A GLB file: one node named `name` with one triangle primitive (positions, u32 indices).
fn glb(p: &[Vec3], t: &[[u32; 3]], name: &str) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    for v in p {
        for c in v.to_array() {
            bin.extend(c.to_le_bytes());
        }
    }
    let positions_len = bin.len();
    for tri in t {
        for v in tri {
            bin.extend(v.to_le_bytes());
        }
    }
    let (lo, hi) = p
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
    let json = format!(
        r#"{{"asset":{{"version":"2.0","generator":"hooke examples/make_meshes.rs"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"name":"{name}","mesh":0}}],"meshes":[{{"name":"{name}","primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":4}}]}}],"accessors":[{{"bufferView":0,"componentType":5126,"count":{np},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}},{{"bufferView":1,"componentType":5125,"count":{ni},"type":"SCALAR"}}],"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{positions_len},"target":34962}},{{"buffer":0,"byteOffset":{positions_len},"byteLength":{il},"target":34963}}],"buffers":[{{"byteLength":{bl}}}]}}"#,
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z,
        np = p.len(),
        ni = 3 * t.len(),
        il = 12 * t.len(),
        bl = bin.len(),
    );
    let mut json = json.into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

/// A small deterministic generator (xorshift64*): the meshes are the same on every machine.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}
