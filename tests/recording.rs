//! What a recording holds, read back from the .rrd with Rerun's own decoder and compared with the
//! snapshots it was made from: surfaces (triangles, vertex positions and colours, tearing),
//! spring lines and their hover values, the strain histogram, and the documented vertex strain.
//! What the recording options give is in tests/recording_options.rs.

use crate::common;

use hooke::integrator::Step;
use std::collections::{BTreeMap, HashSet};

use crate::common::record::{Rows, at_frame, read_components, record, stepped};
use crate::common::temp_dir;
use glam::Vec3;
use hooke::backend::Backend as _;
use hooke::model::Model;
use hooke::record::{
    RecordOptions, SpringSelection, shading, strain_color, surface, surface_strain,
};
use hooke::state::Snapshot;
use rerun::Loggable as _;
use rerun::external::arrow::array::{Array as _, ArrayRef, Float32Array, StringArray};

fn positions(a: &ArrayRef) -> Vec<Vec3> {
    rerun::components::Position3D::from_arrow(a)
        .unwrap_or_else(|e| panic!("{e}"))
        .into_iter()
        .map(|p| Vec3::new(p.x(), p.y(), p.z()))
        .collect()
}

fn triangles(a: &ArrayRef) -> Vec<[u32; 3]> {
    rerun::components::TriangleIndices::from_arrow(a)
        .unwrap_or_else(|e| panic!("{e}"))
        .into_iter()
        .map(|t| [t.0.x(), t.0.y(), t.0.z()])
        .collect()
}

fn colors(a: &ArrayRef) -> Vec<[u8; 3]> {
    rerun::components::Color::from_arrow(a)
        .unwrap_or_else(|e| panic!("{e}"))
        .into_iter()
        .map(|c| {
            let [r, g, b, _] = c.to_array();
            [r, g, b]
        })
        .collect()
}

fn floats(a: &ArrayRef) -> Vec<f32> {
    a.as_any()
        .downcast_ref::<Float32Array>()
        .unwrap_or_else(|| panic!("not f32: {:?}", a.data_type()))
        .values()
        .to_vec()
}

/// Grid coordinates of a body's local mass index.
fn coords(grid: &[u32], i: u32) -> [u32; 3] {
    let n = [0, 1, 2].map(|a| grid.get(a).copied().unwrap_or(1));
    [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])]
}

/// The strain of the most strained intact structural spring at each mass (0 where none), from
/// the snapshot.
fn strain_at_masses(model: &Model, snap: &Snapshot) -> Vec<f32> {
    let mut best = vec![0.0f32; model.mass_count()];
    for (s, sp) in model.springs.iter().enumerate() {
        let e = snap.strain[s];
        if e.is_nan() || model.spring_kind[s] != hooke::model::SpringKindTag::Structural {
            continue;
        }
        for m in [sp.a, sp.b] {
            if e.abs() > best[m as usize].abs() {
                best[m as usize] = e;
            }
        }
    }
    best
}

/// Checks one body's surface at `frame` against `snap`: the vertices are `vertex_masses` (mass
/// order), the triangle count is `triangles`, and every colour is the documented function.
struct Want<'a> {
    body: &'a str,
    vertex_masses: &'a [u32],
    triangles: usize,
    two_sided: bool,
    range: f32,
}

fn check_surface(c: &BTreeMap<(String, String), Rows>, model: &Model, snap: &Snapshot, w: &Want) {
    let Want {
        body,
        vertex_masses,
        triangles: want_triangles,
        two_sided,
        range,
    } = *w;
    let entity = format!("/world/{body}/surface");
    let frame = snap.frame as i64;
    let tris = triangles(at_frame(c, &entity, "Mesh3D:triangle_indices", frame));
    assert_eq!(tris.len(), want_triangles, "{body}: triangles");
    let pos = positions(at_frame(c, &entity, "Mesh3D:vertex_positions", frame));
    let want: Vec<Vec3> = vertex_masses
        .iter()
        .map(|&m| snap.positions[m as usize])
        .collect();
    assert_eq!(pos, want, "{body}: vertex positions are the snapshot's");
    // Colour: strain of the most strained spring at the vertex, on the strain scale, lit by the
    // viewer's lighting of the (area-weighted) vertex normal.
    let mut normals = vec![Vec3::ZERO; pos.len()];
    for t in &tris {
        let n = (pos[t[1] as usize] - pos[t[0] as usize])
            .cross(pos[t[2] as usize] - pos[t[0] as usize]);
        for v in t {
            normals[*v as usize] += n;
        }
    }
    let strain = strain_at_masses(model, snap);
    let got = colors(at_frame(c, &entity, "Mesh3D:vertex_colors", frame));
    assert_eq!(got.len(), pos.len());
    let mut distinct = HashSet::new();
    for (v, &m) in vertex_masses.iter().enumerate() {
        let want = shading::shaded(
            strain_color(strain[m as usize], range),
            shading::shade(normals[v].normalize_or_zero(), two_sided),
        );
        assert_eq!(got[v], want, "{body}: colour of vertex {v} (mass {m})");
        distinct.insert(got[v]);
    }
    // At rest (frame 0) every vertex is alike; once it moves, strain and light vary.
    if snap.frame > 0 {
        assert!(distinct.len() > 10, "{body}: colours vary: {distinct:?}");
    }
}

#[test]
fn a_sheet_and_a_block_record_their_surface_with_the_snapshot_positions_and_strain_colours() {
    let dir = temp_dir("surface");
    // cloth: a 32 × 32 sheet, 31 × 31 quads of two triangles; jello: a 10³ block, six faces of
    // 9 × 9 quads, its 10³ − 8³ outer masses as vertices.
    for (scene, body, triangles, two_sided) in [
        ("cloth", "cloth", 31 * 31 * 2, true),
        ("jello", "jello", 6 * 9 * 9 * 2, false),
    ] {
        let (loaded, model, snaps) = stepped(scene, 20);
        let path = dir.join(format!("{scene}.rrd"));
        record(&loaded, &model, &snaps, RecordOptions::default(), &path);
        let c = read_components(&path);
        let b = &model.bodies[0];
        let grid = b.grid().expect("a grid body");
        let vertex_masses: Vec<u32> = b
            .masses
            .clone()
            .filter(|&m| {
                let g = coords(grid, m - b.masses.start);
                grid.len() == 2 || (0..3).any(|a| g[a] == 0 || g[a] + 1 == grid[a])
            })
            .collect();
        if scene == "jello" {
            assert_eq!(vertex_masses.len(), 1000 - 512);
        }
        let want = Want {
            body,
            vertex_masses: &vertex_masses,
            triangles,
            two_sided,
            range: loaded.scene.view.strain_range,
        };
        for snap in &snaps {
            check_surface(&c, &model, snap, &want);
        }
        // Triangle indices never change here: logged once, static.
        let idx = &c[&(
            format!("/world/{body}/surface"),
            "Mesh3D:triangle_indices".into(),
        )];
        assert_eq!(idx.len(), 1, "{scene}: triangle indices logged once");
        assert_eq!(idx[0].0, None, "{scene}: triangle indices are static");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_torn_spring_removes_its_triangles_from_the_surface() {
    // tear: the sphere breaks the cloth's springs within its first second.
    let hooke::run::prepare::Planned {
        loaded,
        settings,
        model,
    } = hooke::run::prepare::planned("tear").unwrap_or_else(|e| panic!("{e}"));
    let mut be = hooke::cpu::CpuBackend::new(
        model.clone(),
        Step::new(settings.integrator, settings.dt_secs),
    );
    let mut snaps = vec![
        be.snapshot(0, Default::default())
            .unwrap_or_else(|e| panic!("{e}")),
    ];
    for frame in 1..=120 {
        be.advance(settings.substeps)
            .unwrap_or_else(|e| panic!("{e}"));
        let s = be
            .snapshot(frame, Default::default())
            .unwrap_or_else(|e| panic!("{e}"));
        let torn = s.broken_springs() > 0;
        snaps.push(s);
        if torn {
            break;
        }
    }
    let last = snaps.last().unwrap_or_else(|| panic!("no frames"));
    let broken: HashSet<(u32, u32)> = (0..model.spring_count())
        .filter(|&s| last.strain[s].is_nan())
        .map(|s| {
            let sp = model.springs[s];
            (sp.a.min(sp.b), sp.a.max(sp.b))
        })
        .collect();
    assert!(!broken.is_empty(), "the tear scene tore nothing in 2 s");
    let dir = temp_dir("tear");
    let path = dir.join("tear.rrd");
    record(&loaded, &model, &snaps, RecordOptions::default(), &path);
    let c = read_components(&path);
    let entity = "/world/cloth/surface";
    let before = triangles(at_frame(&c, entity, "Mesh3D:triangle_indices", 0));
    assert_eq!(before.len(), 31 * 31 * 2);
    let after = triangles(at_frame(
        &c,
        entity,
        "Mesh3D:triangle_indices",
        last.frame as i64,
    ));
    // The sheet's vertices are its masses: vertex v is mass v. A triangle goes when a spring along
    // one of its edges broke.
    let edge_broke = |t: &[u32; 3]| {
        [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
            .iter()
            .any(|&(a, b)| broken.contains(&(a.min(b), a.max(b))))
    };
    let want: Vec<[u32; 3]> = before.iter().copied().filter(|t| !edge_broke(t)).collect();
    assert!(want.len() < before.len(), "some triangle has a broken edge");
    assert_eq!(after, want);
    // Indices are resent only when the broken count changes: at frame 0 and at the tear.
    let rows = &c[&(entity.to_owned(), "Mesh3D:triangle_indices".to_owned())];
    let frames: Vec<Option<i64>> = rows.iter().map(|(f, _)| *f).collect();
    assert_eq!(frames, vec![Some(0), Some(last.frame as i64)]);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn hovering_a_spring_reads_the_snapshot_strain_kind_and_rest_length() {
    let (loaded, model, snaps) = stepped("jello", 15);
    let dir = temp_dir("hover");
    let path = dir.join("jello.rrd");
    let all = RecordOptions {
        springs: Some(SpringSelection::All),
        ..RecordOptions::default()
    };
    record(&loaded, &model, &snaps, all, &path);
    let c = read_components(&path);
    let e = "/world/jello/springs";
    // With `--springs all`, every spring is a line, one instance each in spring order.
    let n = model.spring_count();
    let kinds = at_frame(&c, e, "kind", 0);
    let kinds = kinds
        .as_any()
        .downcast_ref::<StringArray>()
        .unwrap_or_else(|| panic!("kind is not text"));
    let rest = floats(at_frame(&c, e, "rest_length_m", 0));
    assert_eq!((kinds.len(), rest.len()), (n, n));
    for (s, r) in rest.iter().enumerate() {
        assert_eq!(kinds.value(s), model.spring_kind[s].name());
        assert_eq!(*r, model.springs[s].rest_m);
    }
    for snap in &snaps {
        let strain = floats(at_frame(&c, e, "strain", snap.frame as i64));
        assert_eq!(strain, snap.strain, "frame {}", snap.frame);
        // The line of spring s runs between its masses' positions in this snapshot.
        let strips = rerun::components::LineStrip3D::from_arrow(at_frame(
            &c,
            e,
            "LineStrips3D:strips",
            snap.frame as i64,
        ))
        .unwrap_or_else(|err| panic!("{err}"));
        assert_eq!(strips.len(), n);
        for (s, strip) in strips.iter().enumerate().step_by(97) {
            let sp = model.springs[s];
            let ends: Vec<Vec3> = strip.0.iter().map(|p| Vec3::from(p.0)).collect();
            assert_eq!(
                ends,
                vec![snap.positions[sp.a as usize], snap.positions[sp.b as usize]]
            );
        }
    }
    assert!(snaps[1].strain.iter().any(|&s| s != 0.0), "the jello moved");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_strain_histogram_counts_every_spring_in_its_bin() {
    let (loaded, model, snaps) = stepped("cloth", 30);
    let dir = temp_dir("histogram");
    let path = dir.join("cloth.rrd");
    record(&loaded, &model, &snaps, RecordOptions::default(), &path);
    let c = read_components(&path);
    let range = loaded.scene.view.strain_range;
    let bins = hooke::record::histogram::BINS;
    for snap in &snaps {
        let values = rerun::components::TensorData::from_arrow(at_frame(
            &c,
            "/stats/strain_histogram",
            "BarChart:values",
            snap.frame as i64,
        ))
        .unwrap_or_else(|e| panic!("{e}"));
        let counts: Vec<u64> = match &values[0].0.buffer {
            rerun::datatypes::TensorBuffer::U64(b) => b.to_vec(),
            other => panic!("histogram values are not counts: {other:?}"),
        };
        assert_eq!(counts.len(), bins + 2);
        assert_eq!(
            counts.iter().sum::<u64>(),
            model.spring_count() as u64,
            "frame {}",
            snap.frame
        );
        // Bar k of the bins holds −range + k·w ≤ strain < −range + (k + 1)·w.
        let w = 2.0 * range / bins as f32;
        let beyond = snap.strain.iter().filter(|s| s.abs() > range).count() as u64;
        assert_eq!(counts[0] + counts[bins + 1], beyond);
        for k in [0usize, bins / 2 - 1, bins / 2, bins - 1] {
            let (lo, hi) = (-range + k as f32 * w, -range + (k + 1) as f32 * w);
            let n = snap
                .strain
                .iter()
                .filter(|&&s| s >= lo && (s < hi || (k == bins - 1 && s <= range)))
                .count() as u64;
            assert_eq!(counts[k + 1], n, "frame {} bin {k}", snap.frame);
        }
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_documented_vertex_strain_is_the_signed_strain_of_the_most_strained_structural_spring() {
    let (_, model, snaps) = stepped("jello", 10);
    let snap = &snaps[1];
    let masses: Vec<u32> = (0..model.mass_count() as u32).collect();
    let mut got = Vec::new();
    surface_strain::vertex_strain(&model, &snap.strain, &masses, &mut got);
    let want = strain_at_masses(&model, snap);
    assert_eq!(got, want);
    assert!(got.iter().any(|s| *s < 0.0) && got.iter().any(|s| *s > 0.0));
}

/// The scan the diverging-run tests rely on finds a NaN or an infinity wherever it is logged
/// (positions, scalars), and nothing in a clean recording.
#[test]
fn the_non_finite_scan_finds_what_it_looks_for() {
    let dir = common::temp_dir("non-finite");
    let path = dir.join("bad.rrd");
    let rec = rerun::RecordingStreamBuilder::new("hooke-test")
        .save(&path)
        .unwrap_or_else(|e| panic!("{e}"));
    rec.log("ok/points", &rerun::Points3D::new([[0.0f32, 1.0, 2.0]]))
        .unwrap_or_else(|e| panic!("{e}"));
    rec.log(
        "bad/points",
        &rerun::Points3D::new([[0.0f32, f32::NAN, 2.0]]),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    rec.log("bad/scalar", &rerun::Scalars::single(f64::INFINITY))
        .unwrap_or_else(|e| panic!("{e}"));
    rec.flush_blocking().unwrap_or_else(|e| panic!("{e}"));
    drop(rec);
    let bad: Vec<String> = common::record::non_finite_components(&path)
        .into_iter()
        .map(|(entity, _)| entity)
        .collect();
    assert_eq!(bad, ["/bad/points", "/bad/scalar"], "{bad:?}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_mesh_cloth_records_its_own_triangles_with_the_snapshot_positions_and_strain_colours() {
    // The flag: 24 × 16 quads of the OBJ, two triangles each; its vertices are its masses, in
    // the model's (Morton) order.
    let dir = temp_dir("surface-mesh");
    let (loaded, model, snaps) = stepped("flag", 20);
    let path = dir.join("flag.rrd");
    record(&loaded, &model, &snaps, RecordOptions::default(), &path);
    let c = read_components(&path);
    let b = &model.bodies[0];
    let vertex_masses: Vec<u32> = b.masses.clone().collect();
    let want = Want {
        body: "flag",
        vertex_masses: &vertex_masses,
        triangles: 24 * 16 * 2,
        two_sided: true,
        range: loaded.scene.view.strain_range,
    };
    for snap in &snaps {
        check_surface(&c, &model, snap, &want);
    }
}

/// A sheet longer than `MAX_SURFACE_SIDE` along x: 520 × 10, so one vertex in 3 (and the last).
const BIG_SHEET: &str = "name = \"big\"\n[[bodies]]\nname = \"s\"\ngrid = [520, 10]\nspacing_m = 0.01\n\
                         mass_kg = 1\n[bodies.springs]\nstructural = { stiffness_n_per_m = 100.0 }\n";

#[test]
fn a_large_sheet_records_one_vertex_in_k_and_keeps_each_blocks_hot_spot() {
    use hooke::record::SurfaceDetail;
    use surface::Surface;
    let model = common::model_of(BIG_SHEET);
    let b = &model.bodies[0];
    let reduced = Surface::of_body(&model, b, SurfaceDetail::Auto).expect("a sheet");
    let full = Surface::of_body(&model, b, SurfaceDetail::Full).expect("a sheet");
    assert_eq!((reduced.stride(), full.stride()), (3, 1));
    // x: 0, 3, …, 519 (174); y: 0, 3, 6, 9.
    assert_eq!(reduced.vertex_mass.len(), 174 * 4);
    assert_eq!(reduced.triangles.len(), 173 * 3 * 2);
    assert_eq!(full.vertex_mass.len(), 520 * 10);
    // One hot spring, between masses (4, 4) and (5, 4): inside the block of vertex (3, 3), and
    // touching no vertex of the reduced surface.
    let mass = |i: u32, j: u32| i + 520 * j;
    let hot = model
        .springs
        .iter()
        .position(|s| (s.a.min(s.b), s.a.max(s.b)) == (mass(4, 4), mass(5, 4)))
        .expect("a structural spring there");
    let mut strain = vec![0.001f32; model.spring_count()];
    strain[hot] = -0.3;
    let mut out = Vec::new();
    reduced.strain(&model, &strain, &mut out);
    let at = |s: &Surface, m: u32| {
        s.vertex_mass
            .iter()
            .position(|&v| v == m)
            .expect("a vertex")
    };
    assert_eq!(out[at(&reduced, mass(3, 3))], -0.3);
    assert_eq!(out.iter().filter(|s| **s == -0.3).count(), 1, "one block");
    assert!(out.iter().all(|s| *s == -0.3 || *s == 0.001));
    // The full surface colours vertex (3, 3) by its own springs, which are cool.
    full.strain(&model, &strain, &mut out);
    assert_eq!(out[at(&full, mass(3, 3))], 0.001);
    assert_eq!(out[at(&full, mass(4, 4))], -0.3);
    // What a run says of it.
    let said = hooke::record::describe(&model, &RecordOptions::default()).join("\n");
    assert!(
        said.contains("one grid vertex in 3") && said.contains("--surface full"),
        "{said}"
    );
    // A body that may tear keeps every vertex: a torn triangle is a spring's.
    let tearing = common::model_of(&format!("{BIG_SHEET}[bodies.tearing]\nmax_strain = 0.5\n"));
    let s = Surface::of_body(&tearing, &tearing.bodies[0], SurfaceDetail::Auto).expect("a sheet");
    assert_eq!(s.stride(), 1);
}

#[test]
fn a_reduced_surface_is_what_the_recording_holds_and_full_is_asked_for_by_flag() {
    let dir = temp_dir("surface-reduced");
    let scene = dir.join("big.toml");
    // At the sheet's stable step: a run above it makes energy, and the watch stops it.
    std::fs::write(
        &scene,
        format!("{BIG_SHEET}[solver]\nframes = 2\nsubsteps = 20\n"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    for (flag, vertices) in [("auto", 174 * 4), ("full", 520 * 10)] {
        let path = dir.join(format!("{flag}.rrd"));
        let out = common::hooke(&common::cpu_run(
            &scene.to_string_lossy(),
            &[
                "--frames",
                "2",
                "--surface",
                flag,
                "--save",
                &path.to_string_lossy(),
            ],
        ));
        assert!(out.status.success(), "{}", common::text(&out.stderr));
        let c = read_components(&path);
        let pos = positions(at_frame(
            &c,
            "/world/s/surface",
            "Mesh3D:vertex_positions",
            2,
        ));
        assert_eq!(pos.len(), vertices, "--surface {flag}");
    }
}

#[test]
fn a_frame_digested_on_the_simulation_thread_records_exactly_as_one_the_recorder_digests() {
    // The large sheet (a reduced surface, block strains) with a wave through it.
    let scene = common::ok(hooke::scene::from_toml(
        BIG_SHEET,
        hooke::scene::SceneOrigin::Text,
    ));
    let loaded = hooke::scene::LoadedScene {
        scene,
        origin: hooke::scene::SceneOrigin::Text,
        text: BIG_SHEET.to_owned(),
    };
    let model = common::model_of(BIG_SHEET);
    let snaps: Vec<Snapshot> = (0..3u64)
        .map(|k| {
            let positions: Vec<Vec3> = model
                .initial
                .x
                .iter()
                .map(|x| *x + Vec3::Z * 0.002 * (x.x * 40.0 + k as f32).sin())
                .collect();
            Snapshot {
                strain: model.springs.iter().map(|s| s.strain(&positions)).collect(),
                positions,
                ..Snapshot::at(k, k as f64 / 60.0, k)
            }
        })
        .collect();
    let dir = temp_dir("digest");
    let opts = RecordOptions::default();
    let plain = dir.join("plain.rrd");
    record(&loaded, &model, &snaps, opts, &plain);
    let (rec, _) = common::ok(rerun::RecordingStreamBuilder::new("digest").memory());
    let digester =
        hooke::record::Recorder::new(rec, model.clone(), opts.for_scene(&loaded.scene)).digester();
    let digested: Vec<Snapshot> = snaps
        .iter()
        .cloned()
        .map(|mut s| {
            digester.digest(&mut s);
            s
        })
        .collect();
    assert!(
        digested[1]
            .digest
            .as_ref()
            .is_some_and(|d| !d.surfaces[0].is_empty())
    );
    let made = dir.join("digested.rrd");
    record(&loaded, &model, &digested, opts, &made);
    let (mut a, mut b) = (read_components(&plain), read_components(&made));
    for c in [&mut a, &mut b] {
        // The time each frame took to record, and when the recording began, differ, and so do
        // the ids of the layout's views and containers (new each time a layout is made).
        c.retain(|(e, _), _| {
            e != "/stats/record_ms"
                && e != "/__properties"
                && ![
                    "/view/",
                    "/container/",
                    "/viewport",
                    "/time_panel",
                    "/selection_panel",
                    "/blueprint_panel",
                    "/top_panel",
                ]
                .iter()
                .any(|p| e.starts_with(p))
        });
    }
    assert_eq!(a.len(), b.len());
    for (key, rows) in &a {
        assert_eq!(Some(rows), b.get(key), "{key:?}");
    }
}
