//! Mesh bodies: OBJ and glTF files read into cloth (springs on edges, bending across interior
//! edges, shear on quads' diagonals, mass by area), a closed surface filled with a lattice whose
//! cells carry it, pins by vertex, region and group, the recording of a mesh's own surface, and
//! one clear error for each kind of bad mesh. The built-in mesh scenes (flag, tablecloth, blob)
//! run to their end with a flat energy balance in tests/energy.rs and match across backends in
//! tests/gpu.rs, like every built-in scene.

use crate::common;

use std::path::Path;

use crate::common::record::{at_frame, read_components, record, stepped};
use crate::common::{hooke, ok, temp_dir, text};
use glam::Vec3;
use hooke::mesh::{Format, MAX_TRIANGLES};
use hooke::model::{BodyShape, MeshVertices, Model, SpringKindTag};
use hooke::record::RecordOptions;
use hooke::scene::SceneOrigin;
use rerun::Loggable as _;

/// A mesh the built-in scenes use, by file name.
fn built_in_mesh(name: &str) -> &'static [u8] {
    hooke::scene::BUILT_IN_MESHES
        .iter()
        .find(|(p, _)| p.ends_with(name))
        .map(|(_, b)| *b)
        .unwrap_or_else(|| panic!("no built-in mesh {name}"))
}

/// A scene with one mesh body, `body` the rest of its table (after `mesh = …`).
fn scene_text(mesh: &str, body: &str) -> String {
    format!(
        "name = \"m\"\n[solver]\nsubsteps = 10\nframes = 2\n[effects]\ngravity_m_per_s2 = [0, -9.81, 0]\n\
         [[bodies]]\nname = \"b\"\nmesh = \"{mesh}\"\nmass_kg = 2.0\n{body}\n"
    )
}

/// Load scene text as if from `dir/scene.toml`.
fn load(dir: &Path, toml: &str) -> Result<hooke::scene::Scene, hooke::scene::SceneError> {
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).unwrap_or_else(|e| panic!("{e}"));
    hooke::scene::from_toml(toml, SceneOrigin::File(path))
}

fn model(dir: &Path, toml: &str) -> Model {
    hooke::model::build(&ok(load(dir, toml)))
}

/// The error a scene is refused with, which must be one line naming `what`.
fn refused(dir: &Path, toml: &str, what: &[&str]) -> String {
    let e = match load(dir, toml) {
        Ok(_) => panic!("accepted:\n{toml}"),
        Err(e) => e.to_string(),
    };
    assert!(!e.contains('\n'), "one line: {e}");
    for w in what {
        assert!(e.contains(w), "{e:?} does not say {w:?}");
    }
    e
}

const SPRINGS: &str = "[bodies.springs]\nstructural = { stiffness_n_per_m = 100.0 }\n\
                       shear = { stiffness_n_per_m = 20.0 }\nbending = { stiffness_n_per_m = 2.0 }\n";

/// Two unit quads side by side: 0 1 2 along x at y = 0, 3 4 5 at y = 1.
const STRIP: &str = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\nf 1 2 5 4\nf 2 3 6 5\n";

#[test]
fn two_quads_become_cloth_with_a_spring_per_edge_shear_on_diagonals_bending_across_and_mass_by_area()
 {
    let dir = temp_dir("mesh-strip");
    std::fs::write(dir.join("strip.obj"), STRIP).unwrap_or_else(|e| panic!("{e}"));
    let m = model(&dir, &scene_text("strip.obj", SPRINGS));
    assert_eq!(m.mass_count(), 6);
    // Seven sides, both diagonals of both quads, and one bending spring across the shared
    // edge (1, 4), between the corners opposite it: 0 and 5.
    assert_eq!(m.springs_of_kind(SpringKindTag::Structural), 7);
    assert_eq!(m.springs_of_kind(SpringKindTag::Shear), 4);
    assert_eq!(m.springs_of_kind(SpringKindTag::Bending), 1);
    let x = &m.initial.x;
    let at = |p: Vec3| x.iter().position(|q| *q == p).expect("a vertex there") as u32;
    let bend = m
        .springs
        .iter()
        .zip(&m.spring_kind)
        .find(|(_, k)| **k == SpringKindTag::Bending)
        .map(|(s, _)| (s.a.min(s.b), s.a.max(s.b)))
        .expect("one bending spring");
    let (v0, v5) = (at(Vec3::ZERO), at(Vec3::new(2.0, 1.0, 0.0)));
    assert_eq!(bend, (v0.min(v5), v0.max(v5)));
    for s in &m.springs {
        let rest = x[s.a as usize].distance(x[s.b as usize]);
        assert!((s.rest_m - rest).abs() < 1e-6);
    }
    // Each triangle (area 1/2) gives a third to each corner: 2 kg over an area of 2 m².
    let want = [
        (Vec3::ZERO, 1.0 / 3.0),
        (Vec3::X, 0.5),
        (Vec3::new(2.0, 0.0, 0.0), 1.0 / 6.0),
        (Vec3::Y, 1.0 / 6.0),
        (Vec3::new(1.0, 1.0, 0.0), 0.5),
        (Vec3::new(2.0, 1.0, 0.0), 1.0 / 3.0),
    ];
    for (p, kg) in want {
        let got = m.mass_kg[at(p) as usize];
        assert!((got - kg).abs() < 1e-6, "mass at {p}: {got} kg, want {kg}");
    }
    let BodyShape::Mesh(shape) = &m.bodies[0].shape else {
        panic!("a mesh body")
    };
    assert_eq!(shape.triangles.len(), 4);
    assert!(!shape.closed);
}

#[test]
fn the_obj_and_the_glb_of_one_surface_build_the_same_model() {
    let dir = temp_dir("mesh-formats");
    let glb = built_in_mesh("tablecloth.glb");
    let mesh = ok(hooke::mesh::read(glb, Format::Gltf, &|_| {
        Err(std::io::ErrorKind::NotFound.into())
    }));
    assert_eq!(mesh.triangles.len(), 2 * 36 * 36);
    assert_eq!(mesh.group("tablecloth").map(<[u32]>::len), Some(37 * 37));
    // The same surface as OBJ text (Rust prints an f32 so that it reads back exactly).
    let mut obj = String::new();
    for p in &mesh.positions {
        obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for t in &mesh.triangles {
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(dir.join("cloth.obj"), obj).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(dir.join("cloth.glb"), glb).unwrap_or_else(|e| panic!("{e}"));
    let springs = "[bodies.springs]\nstructural = { stiffness_n_per_m = 100.0 }\nbending = { stiffness_n_per_m = 2.0 }\n";
    let a = model(&dir, &scene_text("cloth.obj", springs));
    let b = model(&dir, &scene_text("cloth.glb", springs));
    assert_eq!(a.initial, b.initial);
    assert_eq!(a.springs, b.springs);
    assert_eq!(a.mass_kg, b.mass_kg);
    // glTF with its buffer beside it, as a .bin file: the same again.
    let (json, bin) = glb_chunks(glb);
    let json = json.replace("\"buffers\":[{", "\"buffers\":[{\"uri\":\"cloth.bin\",");
    std::fs::write(dir.join("cloth.gltf"), json).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(dir.join("cloth.bin"), bin).unwrap_or_else(|e| panic!("{e}"));
    let c = model(&dir, &scene_text("cloth.gltf", springs));
    assert_eq!(a.initial, c.initial);
    assert_eq!(a.springs, c.springs);
    // Without the .bin, one clear error naming it.
    std::fs::remove_file(dir.join("cloth.bin")).unwrap_or_else(|e| panic!("{e}"));
    refused(
        &dir,
        &scene_text("cloth.gltf", springs),
        &["bodies[0].mesh", "cloth.gltf", "cloth.bin"],
    );
}

/// A GLB's JSON text and binary chunk.
fn glb_chunks(glb: &[u8]) -> (String, Vec<u8>) {
    let u32_at =
        |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().expect("4 bytes")) as usize;
    let json_len = u32_at(12);
    let json = String::from_utf8(glb[20..20 + json_len].to_vec()).expect("utf-8");
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at);
    (
        json.trim_end().to_owned(),
        glb[bin_at + 8..bin_at + 8 + bin_len].to_vec(),
    )
}

#[test]
fn masses_are_numbered_along_a_space_filling_curve() {
    // The tablecloth's file numbers its vertices at random: in the model, a spring's two ends
    // are close in memory, as on a grid.
    let (_, model, _) = stepped("tablecloth", 0);
    let spread: Vec<u32> = model.springs.iter().map(|s| s.a.abs_diff(s.b)).collect();
    let mut sorted = spread.clone();
    sorted.sort_unstable();
    let median = sorted[sorted.len() / 2];
    // 37 × 37 vertices: random numbering would put the median gap near 1369 / 3.
    assert!(median < 40, "median index gap {median}");
}

#[test]
fn pins_by_vertex_by_region_and_by_group() {
    let dir = temp_dir("mesh-pins");
    std::fs::write(dir.join("flag.obj"), built_in_mesh("flag.obj"))
        .unwrap_or_else(|e| panic!("{e}"));
    let pinned = |m: &Model| -> Vec<Vec3> {
        (0..m.mass_count())
            .filter(|&i| m.inv_mass[i] == 0.0)
            .map(|i| m.initial.x[i])
            .collect()
    };
    // The group `hoist` is the first column of quads: the vertices at x = 0 and x = 0.05.
    let m = model(&dir, &scene_text("flag.obj", "pin_groups = [\"hoist\"]"));
    let p = pinned(&m);
    assert_eq!(p.len(), 2 * 17);
    assert!(p.iter().all(|q| q.x < 0.051), "{p:?}");
    // A box round the top edge (y = 0.8), and a ball round the bottom fly corner.
    let m = model(
        &dir,
        &scene_text(
            "flag.obj",
            "pins_in = [{ min_m = [-1, 0.79, -1], max_m = [2, 0.81, 1] }, { center_m = [1.2, 0, 0], radius_m = 0.01 }]",
        ),
    );
    let p = pinned(&m);
    assert_eq!(p.len(), 25 + 1);
    // By vertex index: the mesh's own numbering (the order faces first use them).
    let m = model(&dir, &scene_text("flag.obj", "pins = [[0], [1]]"));
    assert_eq!(pinned(&m).len(), 2);
    // The same as a flat list (`pins = [0, 10]` once said "invalid type: integer").
    let flat = model(&dir, &scene_text("flag.obj", "pins = [0, 1]"));
    assert_eq!(pinned(&flat), pinned(&m));
    refused(
        &dir,
        &scene_text("flag.obj", "pins = [\"corner\"]"),
        &[
            "bodies[0].pins",
            "a grid index (`[i, j]`) or a mesh vertex (`v` or `[v]`)",
        ],
    );
    refused(
        &dir,
        &scene_text("flag.obj", "pin_groups = [\"pole\"]"),
        &[
            "bodies[0].pin_groups[0]",
            "no group named 'pole'",
            "hoist, fly",
        ],
    );
    refused(
        &dir,
        &scene_text("flag.obj", "pins = [[425]]"),
        &["bodies[0].pins[0][0]", "vertex 425", "0 to 424"],
    );
    refused(
        &dir,
        &scene_text(
            "flag.obj",
            "pins_in = { center_m = [5, 5, 5], radius_m = 0.1 }",
        ),
        &[
            "bodies[0].pins_in[0]",
            "holds none of the masses of body 'b'",
        ],
    );
    refused(
        &dir,
        &scene_text(
            "flag.obj",
            "pins_in = { min_m = [0, 0, 0], radius_m = 0.1 }",
        ),
        &["bodies[0].pins_in[0]", "a box", "a ball"],
    );
}

#[test]
fn a_lattice_carries_the_surface_from_where_the_mesh_is_and_keeps_it_on_its_cells() {
    let (loaded, model, snaps) = stepped("blob", 30);
    let body = &model.bodies[0];
    let BodyShape::Mesh(shape) = &body.shape else {
        panic!("a mesh body")
    };
    let MeshVertices::Embedded(embedded) = &shape.vertices else {
        panic!("a filled mesh")
    };
    let placed = loaded.scene.bodies[0].placed_vertices();
    assert_eq!(embedded.len(), placed.len());
    for (e, p) in embedded.iter().zip(&placed) {
        let at = e.position(&model.initial.x, 0);
        assert!((at - *p).length() < 1e-5, "{at} vs {p}");
        assert!(e.weights.iter().all(|w| (0.0..=1.0).contains(w)));
    }
    // The lattice is inside-out free: every node is a corner of a cell, no node without springs.
    for m in body.masses.clone() {
        assert!(
            !model.adjacency.of(m as usize).is_empty(),
            "mass {m} has no spring"
        );
    }
    // The recording draws the mesh's own triangles at the embedded positions.
    let dir = temp_dir("mesh-blob");
    let path = dir.join("blob.rrd");
    record(&loaded, &model, &snaps, RecordOptions::default(), &path);
    let c = read_components(&path);
    let last = &snaps[1];
    let entity = "/world/blob/surface";
    let pos = rerun::components::Position3D::from_arrow(at_frame(
        &c,
        entity,
        "Mesh3D:vertex_positions",
        last.frame as i64,
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(pos.len(), placed.len());
    for (e, p) in embedded.iter().zip(&pos) {
        let want = e.position(&last.positions, 0);
        assert!((Vec3::new(p.x(), p.y(), p.z()) - want).length() < 1e-6);
    }
    let tris = at_frame(&c, entity, "Mesh3D:triangle_indices", last.frame as i64);
    assert_eq!(tris.len(), shape.triangles.len());
    // No lattice lines by default: the surface is what is drawn.
    assert!(!c.keys().any(|(e, _)| e == "/world/blob/springs"));
}

#[test]
fn hooke_check_names_the_mesh_and_what_it_became() {
    for (scene, says) in [
        (
            "flag",
            "mesh ../meshes/flag.obj (768 triangles, cloth), 425 masses",
        ),
        (
            "tablecloth",
            "mesh ../meshes/tablecloth.glb (2592 triangles, cloth)",
        ),
        ("blob", "(1280 triangles, filled with a lattice)"),
    ] {
        let out = hooke(&["check", scene, "--backend", "cpu"]);
        let s = text(&out.stdout);
        assert!(out.status.success(), "{}", text(&out.stderr));
        assert!(s.contains(says), "{scene}: {s}");
    }
}

#[test]
fn each_bad_mesh_is_refused_with_one_clear_error() {
    let dir = temp_dir("mesh-bad");
    let write = |name: &str, body: &str| {
        std::fs::write(dir.join(name), body).unwrap_or_else(|e| panic!("{e}"));
    };
    refused(
        &dir,
        &scene_text("nowhere.obj", ""),
        &[
            "bodies[0].mesh",
            "nowhere.obj",
            "relative to the scene file's folder",
        ],
    );
    refused(&dir, &scene_text("flag.stl", ""), &["neither OBJ nor glTF"]);
    write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    refused(
        &dir,
        &scene_text("points.obj", ""),
        &["points.obj", "no triangles"],
    );
    write("broken.glb", "glTF this is not");
    refused(
        &dir,
        &scene_text("broken.glb", ""),
        &["broken.glb", "glTF reader"],
    );
    // Three triangles on one edge: no bending across it, no lattice in it.
    write(
        "fin.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 2 5\n",
    );
    refused(
        &dir,
        &scene_text("fin.obj", SPRINGS),
        &["fin.obj", "shared by 3 triangles", "remove springs.bending"],
    );
    let no_bending = "[bodies.springs]\nstructural = { stiffness_n_per_m = 100.0 }\n";
    ok(load(&dir, &scene_text("fin.obj", no_bending)));
    // A sliver: its third corner a hair off the line through the other two.
    write("sliver.obj", "v 0 0 0\nv 1 0 0\nv 0.5 1e-9 0\nf 1 2 3\n");
    refused(
        &dir,
        &scene_text("sliver.obj", no_bending),
        &["sliver.obj", "triangle 0", "degenerate in f32"],
    );
    write("twice.obj", "v 0 0 0\nv 1 0 0\nv 0 0 0\nf 1 2 3\n");
    refused(
        &dir,
        &scene_text("twice.obj", ""),
        &["triangle 0 has two corners at one point"],
    );
    write("nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    refused(&dir, &scene_text("nan.obj", ""), &["nan.obj", "not finite"]);
    // A lattice needs a closed surface and a spacing.
    write("strip.obj", STRIP);
    refused(
        &dir,
        &scene_text("strip.obj", "fill = \"lattice\"\nspacing_m = 0.1"),
        &["bodies[0].fill", "not closed", "fill = \"none\""],
    );
    refused(
        &dir,
        &scene_text("strip.obj", "spacing_m = 0.1"),
        &["bodies[0].spacing_m", "a mesh's springs are its edges"],
    );
    refused(
        &dir,
        &scene_text("points.obj", "grid = [2, 2]\nspacing_m = 0.1"),
        &["bodies[0].mesh", "a grid or a mesh, not both"],
    );
    refused(
        &dir,
        "name = \"m\"\n[[bodies]]\nname = \"b\"\ngrid = [2, 2]\nspacing_m = 0.1\nmass_kg = 1\nfill = \"lattice\"\n",
        &["bodies[0].fill", "is for mesh bodies"],
    );
    write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    refused(
        &dir,
        &scene_text("tri.obj", SPRINGS.replace("bending", "#").as_str()),
        &["bodies[0].springs.shear", "no four-sided faces"],
    );
    // A closed cube at a lattice far too fine.
    write("cube.obj", CUBE);
    refused(
        &dir,
        &scene_text("cube.obj", "fill = \"lattice\"\nspacing_m = 1e-4"),
        &[
            "bodies[0].spacing_m",
            "more than the limit",
            "larger spacing_m",
        ],
    );
    let m = model(
        &dir,
        &scene_text(
            "cube.obj",
            &format!("fill = \"lattice\"\nspacing_m = 0.3\n{SPRINGS}"),
        ),
    );
    assert_eq!(m.mass_count(), 125);
}

/// A one-triangle glTF with its buffer inline: positions (VEC3, FLOAT), indices of component
/// type `index_type` and count `index_count`, and the scene's `nodes`.
fn triangle_gltf(index_type: u32, index_count: u32, nodes: &str) -> String {
    use base64::Engine as _;
    let mut bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    bin.extend([0u16, 1, 2, 0].iter().flat_map(|i| i.to_le_bytes()));
    let data = base64::engine::general_purpose::STANDARD.encode(&bin);
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":{nodes},
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":{index_type},"count":{index_count},"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":8}}],
"buffers":[{{"byteLength":44,"uri":"data:application/octet-stream;base64,{data}"}}]}}"#
    )
}

/// What `gltf` 1.4 reads without checking is checked first: a float index accessor (the reader
/// reached `unreachable!`: a panic and exit 101), a cycle of nodes (the walk grew to 6 GB), an
/// accessor past its buffer view; each is one error naming the file and what is wrong.
#[test]
fn a_gltf_that_would_crash_its_reader_is_refused_with_what_is_wrong() {
    let dir = temp_dir("mesh-gltf-guard");
    let write = |name: &str, body: &str| {
        std::fs::write(dir.join(name), body).unwrap_or_else(|e| panic!("{e}"));
    };
    let no_bending = "[bodies.springs]\nstructural = { stiffness_n_per_m = 100.0 }\n";
    write("good.gltf", &triangle_gltf(5123, 3, r#"[{"mesh":0}]"#));
    assert_eq!(
        model(&dir, &scene_text("good.gltf", no_bending)).mass_count(),
        3
    );
    write("float.gltf", &triangle_gltf(5126, 3, r#"[{"mesh":0}]"#));
    refused(
        &dir,
        &scene_text("float.gltf", no_bending),
        &[
            "float.gltf",
            "accessor 1",
            "components are F32",
            "indices of one unsigned",
        ],
    );
    write(
        "cycle.gltf",
        &triangle_gltf(5123, 3, r#"[{"mesh":0,"children":[1]},{"children":[0]}]"#),
    );
    refused(
        &dir,
        &scene_text("cycle.gltf", no_bending),
        &["cycle.gltf", "node 0 is its own ancestor"],
    );
    write("long.gltf", &triangle_gltf(5123, 3000, r#"[{"mesh":0}]"#));
    refused(
        &dir,
        &scene_text("long.gltf", no_bending),
        &[
            "long.gltf",
            "accessor 1",
            "3000 elements reach byte 6000",
            "8 bytes long",
        ],
    );
    // Files with no triangles say which part gave none and why (three broken files
    // all said "it has no triangles"; a primitive without POSITION is the reader's own error).
    let good = triangle_gltf(5123, 3, r#"[{"mesh":0}]"#);
    for (name, from, to, says) in [
        (
            "lines.gltf",
            r#""indices":1}"#,
            r#""indices":1,"mode":1}"#,
            "mesh 0's primitive 0 is in mode LINES, and only TRIANGLES make a surface",
        ),
        (
            "past.gltf",
            r#""componentType":5126,"count":3"#,
            r#""componentType":5126,"count":2"#,
            "mesh 0's primitive 0 has indices up to 2, past its 2 vertices",
        ),
        (
            "unplaced.gltf",
            r#""nodes":[{"mesh":0}]"#,
            r#""nodes":[{"name":"empty"}]"#,
            "its scene places none of its 1 mesh(es) on a node",
        ),
    ] {
        assert!(good.contains(from), "{name}: no `{from}`");
        write(name, &good.replace(from, to));
        refused(
            &dir,
            &scene_text(name, no_bending),
            &[name, "it has no triangles", says],
        );
    }
}

/// A unit cube, its faces quads.
const CUBE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n\
                    f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";

#[test]
fn a_mesh_beyond_the_triangle_limit_is_refused_before_it_is_built() {
    let dir = temp_dir("mesh-huge");
    // A strip of quads with more triangles than a body may have: read, then refused by count.
    let quads = MAX_TRIANGLES / 2 + 1;
    let mut obj = String::with_capacity(40 * quads);
    for i in 0..=quads {
        obj += &format!("v {i} 0 0\nv {i} 1 0\n");
    }
    for i in 0..quads {
        let a = 2 * i + 1;
        obj += &format!("f {} {} {} {}\n", a, a + 2, a + 3, a + 1);
    }
    std::fs::write(dir.join("huge.obj"), obj).unwrap_or_else(|e| panic!("{e}"));
    refused(
        &dir,
        &scene_text("huge.obj", ""),
        &["huge.obj", &format!("more than the {MAX_TRIANGLES}")],
    );
}

#[test]
fn tearing_plasticity_and_self_collision_work_on_a_mesh_cloth() {
    use hooke::backend::Backend as _;
    let dir = temp_dir("mesh-effects");
    let glb = built_in_mesh("tablecloth.glb");
    std::fs::write(dir.join("cloth.glb"), glb).unwrap_or_else(|e| panic!("{e}"));
    // The 1.6 m cloth held along its four edges (four boxes), struck from below by a sphere
    // at 3 m/s: it stretches, yields, tears, and its torn flaps fold onto each other.
    let body = "pins_in = [\n\
        { min_m = [-0.81, -0.1, -0.81], max_m = [-0.79, 0.1, 0.81] },\n\
        { min_m = [0.79, -0.1, -0.81], max_m = [0.81, 0.1, 0.81] },\n\
        { min_m = [-0.81, -0.1, -0.81], max_m = [0.81, 0.1, -0.79] },\n\
        { min_m = [-0.81, -0.1, 0.79], max_m = [0.81, 0.1, 0.81] },\n]\n\
        [bodies.springs]\nstructural = { stiffness_n_per_m = 100.0, damping_n_s_per_m = 0.01 }\n\
        bending = { stiffness_n_per_m = 2.0 }\n\
        [bodies.plasticity]\nyield_strain = 0.05\ncreep_per_s = 20.0\n\
        [bodies.tearing]\nmax_strain = 0.25\n";
    let plain = scene_text("cloth.glb", body);
    let finest = ok(load(&dir, &plain)).bodies[0].finest_spacing_m();
    let toml = plain.replace(
        "[[bodies]]",
        &format!(
            "[[effects.spheres]]\ncenter_m = [0, -0.4, 0]\nvelocity_m_per_s = [0, 3, 0]\nradius_m = 0.2\n\
             stiffness_n_per_m = 1000.0\n\
             [effects.self_collision]\nradius_m = {}\nstiffness_n_per_m = 100.0\n[[bodies]]",
            0.45 * finest
        ),
    );
    let scene = ok(load(&dir, &toml));
    let model = std::sync::Arc::new(hooke::model::build(&scene));
    assert!(model.effects.tearing && model.effects.plasticity);
    assert!(model.effects.self_collision.is_some());
    let mut be = hooke::cpu::CpuBackend::new(
        model.clone(),
        hooke::integrator::Step::new(hooke::integrator::Integrator::SemiImplicit, 1.0e-4),
    );
    let mut contact = 0.0f64;
    let mut last = None;
    for frame in 1..=30 {
        let stats = be.advance(100).unwrap_or_else(|e| panic!("{e}"));
        let s = be.snapshot(frame, stats).unwrap_or_else(|e| panic!("{e}"));
        contact = contact.max(s.energies.contact_j);
        last = Some(s);
    }
    let s = last.expect("frames");
    let broken = s.strain.iter().filter(|x| x.is_nan()).count();
    assert!(broken > 10, "{broken} springs broke");
    assert!(s.energies.ledger.plastic_j > 0.0, "nothing yielded");
    assert!(contact > 0.0, "no contact");
    // The torn edges open the recorded surface.
    let surface =
        hooke::record::surface::Surface::of_body(&model, &model.bodies[0], Default::default())
            .expect("a surface");
    assert!(surface.can_tear);
    let intact = surface.intact_triangles(&s.strain).len();
    assert!(
        intact < surface.triangles.len(),
        "{intact} triangles intact of {}",
        surface.triangles.len()
    );
}

#[test]
fn bench_accuracy_measures_a_mesh_scene() {
    let dir = temp_dir("mesh-accuracy");
    let out = hooke(&[
        "bench",
        "accuracy",
        "flag",
        "--backend",
        "cpu",
        "--duration",
        "0.05",
        "--points",
        "2",
        "--out",
        &dir.to_string_lossy(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let table =
        std::fs::read_to_string(dir.join("accuracy-flag.md")).unwrap_or_else(|e| panic!("{e}"));
    for integrator in ["semi-implicit", "rk4", "implicit", "xpbd"] {
        assert!(
            table.contains(&format!("| {integrator} |")),
            "{integrator} missing:\n{table}"
        );
    }
}

#[test]
fn pin_regions_work_on_grid_bodies_too() {
    // A 10 × 10 sheet 0.1 m apart in the xz plane: the box holds the row z = 0, the ball the
    // far corner.
    let m = common::model_of(
        "name = \"g\"\n[[bodies]]\nname = \"s\"\ngrid = [10, 10]\nspacing_m = 0.1\nmass_kg = 1\n\
         axes = [[1, 0, 0], [0, 0, 1]]\n\
         pins_in = [{ min_m = [-1, -1, -0.01], max_m = [2, 1, 0.01] }, { center_m = [0.9, 0, 0.9], radius_m = 0.05 }]\n",
    );
    assert_eq!(m.pinned_count(), 11);
}
