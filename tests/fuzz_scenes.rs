//! A bounded fuzz test of the scene front end: thousands of mutated scene files (bytes flipped,
//! lines cut and spliced, absurd numbers, huge grids, deep nesting), and of mesh files (random
//! OBJ, the flag's OBJ mutated, the tablecloth's GLB with bytes changed or cut), must each give
//! a scene or one clear error, never a panic, and a scene that validates must build its model. The mutator
//! is a fixed-seed xorshift, so a failure reproduces exactly; CI runs it in a few seconds.
//!
//! The adversarial cases run under a 2 GB address space, so that one that grows with its
//! input fails its test instead of the machine: here absurd extents, memory beyond the machine,
//! non-finite ledgers, impacts too fast for the step and buried bodies; in `cli_bad_input.rs`
//! (the same cap) the misleading messages, options that do nothing, the sweep cap and steps f32
//! cannot resolve; in `hard_conditions.rs` stops inside one step and inside one frame, files two
//! runs share and full disks; in `meshes.rs` the glTF files that crashed their reader or had no
//! triangles. Every recording they make is read by `rerun rrd verify` and scanned for NaN.

use crate::common;

use std::panic::{AssertUnwindSafe, catch_unwind};

use hooke::error::SceneOrigin;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const ABSURD: [&str; 14] = [
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "1e308",
    "-1e308",
    "1e-320",
    "18446744073709551615",
    "\"x\"",
    "[]",
    "[[]]",
    "{}",
    "true",
];

fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    for _ in 0..1 + rng.below(4) {
        let n = lines.len().max(1);
        match rng.below(8) {
            0 if !lines.is_empty() => {
                lines.remove(rng.below(n));
            }
            1 if !lines.is_empty() => {
                let l = lines[rng.below(n)].clone();
                lines.insert(rng.below(n), l);
            }
            2 if !lines.is_empty() => {
                // Replace a value with something absurd.
                let i = rng.below(n);
                if let Some(eq) = lines[i].find('=') {
                    let v = ABSURD[rng.below(ABSURD.len())];
                    lines[i] = format!("{}= {v}", &lines[i][..eq]);
                }
            }
            3 if !lines.is_empty() => {
                // Flip a byte (keeping the text valid UTF-8).
                let i = rng.below(n);
                let mut b = lines[i].clone().into_bytes();
                if !b.is_empty() {
                    let k = rng.below(b.len());
                    const BYTES: &[u8] = b"[]{}=,.\"#-0123456789e xyz";
                    b[k] = BYTES[rng.below(BYTES.len())];
                }
                lines[i] = String::from_utf8_lossy(&b).into_owned();
            }
            4 => lines.push(format!(
                "grid = [{}, {}, {}]",
                rng.next() % 200_000,
                rng.next() % 200_000,
                rng.next() % 200_000
            )),
            5 => lines.push(format!(
                "x = {}{}",
                "[".repeat(1 + rng.below(300)),
                "]".repeat(1 + rng.below(300))
            )),
            6 if !lines.is_empty() => {
                let i = rng.below(n);
                let cut = rng.below(lines[i].len() + 1);
                let cut = (0..=cut)
                    .rev()
                    .find(|c| lines[i].is_char_boundary(*c))
                    .unwrap_or(0);
                lines[i].truncate(cut);
            }
            _ => lines.push(format!(
                "[{}]",
                [
                    "solver",
                    "effects",
                    "effects.ground",
                    "[bodies]",
                    "[effects.spheres]",
                    "[effects.boxes]",
                    "[effects.planes]",
                    "bodies.plasticity",
                    "bodies.tearing",
                    "view"
                ][rng.below(10)]
            )),
        }
    }
    lines.join("\n")
}

/// Whether a case was accepted (`true`) or refused with one clear line; a panic fails the test
/// with the case's text.
fn judged(
    i: usize,
    result: std::thread::Result<Result<(), hooke::scene::SceneError>>,
    text: &str,
) -> bool {
    match result {
        Ok(Ok(())) => true,
        Ok(Err(e)) => {
            let msg = e.to_string();
            assert!(
                !msg.is_empty() && !msg.contains('\n'),
                "case {i}: error not one line: {msg:?}\n{text}"
            );
            false
        }
        Err(_) => panic!("case {i} panicked on:\n{text}"),
    }
}

#[test]
fn mutated_scene_files_never_panic() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let (mut accepted, mut rejected) = (0, 0);
    for i in 0..20_000 {
        // The small scenes: every effect's table appears in one of them.
        let small = ["hair", "cloth", "jello", "jello-sphere", "tear", "ramp"];
        let base = hooke::scene::BUILT_IN
            .iter()
            .find(|b| b.name == small[i % small.len()])
            .map_or("", |b| b.toml);
        let text = mutate(&mut rng, base);
        let result = catch_unwind(AssertUnwindSafe(|| {
            hooke::scene::from_toml(&text, SceneOrigin::Text).map(|scene| {
                // Keep the fuzz bounded: build only what a test machine can hold quickly.
                let masses: u64 = scene.bodies.iter().map(|b| b.mass_count_bound()).sum();
                if masses <= 200_000 {
                    let model = hooke::model::build(&scene);
                    assert_eq!(model.mass_count() as u64, masses);
                }
            })
        }));
        if judged(i, result, &text) {
            accepted += 1;
        } else {
            rejected += 1;
        }
    }
    // Both paths were exercised.
    eprintln!("{accepted} mutated scenes accepted, {rejected} rejected with one clear error");
    assert!(
        accepted > 500 && rejected > 5000,
        "accepted {accepted}, rejected {rejected}"
    );
}

/// A random OBJ: vertices (some absurd), faces of 1 to 6 corners (some out of range, relative,
/// zero or with texture and normal indices), groups and junk lines.
fn random_obj(rng: &mut Rng) -> String {
    let mut s = String::new();
    let vertices = 1 + rng.below(40);
    for _ in 0..vertices {
        let mut c = || match rng.below(20) {
            0 => ABSURD[rng.below(ABSURD.len())].to_owned(),
            1 => "1e-30".to_owned(),
            _ => format!("{}", (rng.below(2001) as f32 - 1000.0) / 1000.0),
        };
        let (x, y, z) = (c(), c(), c());
        s += &format!("v {x} {y} {z}\n");
    }
    for _ in 0..rng.below(60) {
        match rng.below(12) {
            0 => s += &format!("g part{}\n", rng.below(3)),
            1 => s += "o thing\nvt 0 0\nvn 0 0 1\n",
            2 => s += "f\n",
            3 => s += "l 1 2\np 1\n# comment\nusemtl none\n",
            _ => {
                s.push('f');
                for _ in 0..1 + rng.below(6) {
                    let v = match rng.below(15) {
                        0 => "0".to_owned(),
                        1 => format!("-{}", 1 + rng.below(vertices + 2)),
                        2 => format!("{}/1/1", 1 + rng.below(vertices)),
                        3 => format!("{}", vertices + 1 + rng.below(5)),
                        _ => format!("{}", 1 + rng.below(vertices)),
                    };
                    s += &format!(" {v}");
                }
                s.push('\n');
            }
        }
    }
    s
}

/// A mesh body's table: cloth or a lattice, with pins of each kind, some of them wrong.
fn random_mesh_body(rng: &mut Rng, file: &str) -> String {
    let mut b = format!("[[bodies]]\nname = \"m\"\nmesh = \"{file}\"\nmass_kg = 1.0\n");
    match rng.below(4) {
        0 => b += "fill = \"lattice\"\nspacing_m = 0.3\n",
        1 => {
            b += &format!(
                "fill = \"lattice\"\nspacing_m = {}\n",
                ["0.05", "1e-3", "0", "-1"][rng.below(4)]
            )
        }
        _ => {}
    }
    match rng.below(6) {
        0 => b += &format!("pins = [[{}]]\n", rng.below(50)),
        1 => b += "pins_in = { min_m = [-1, -1, -1], max_m = [0, 0, 0] }\n",
        2 => b += "pins_in = { center_m = [0, 0, 0], radius_m = 0.5 }\n",
        3 => b += "pin_groups = [\"part1\"]\n",
        _ => {}
    }
    if rng.below(3) > 0 {
        b += "[bodies.springs]\nstructural = { stiffness_n_per_m = 100.0 }\n";
        if rng.below(2) == 0 {
            b += "bending = { stiffness_n_per_m = 2.0 }\n";
        }
        if rng.below(3) == 0 {
            b += "shear = { stiffness_n_per_m = 10.0 }\n";
        }
    }
    b
}

#[test]
fn random_and_mutated_meshes_never_panic() {
    let dir = std::env::temp_dir().join(format!("hooke-fuzz-meshes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let builtin = |name: &str| {
        hooke::scene::BUILT_IN_MESHES
            .iter()
            .find(|(p, _)| p.ends_with(name))
            .map_or(&[][..], |(_, b)| *b)
    };
    let flag = String::from_utf8_lossy(builtin("flag.obj")).into_owned();
    let glb = builtin("tablecloth.glb");
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    let (mut accepted, mut rejected) = (0, 0);
    for i in 0..3_000 {
        let (file, bytes): (&str, Vec<u8>) = match i % 3 {
            0 => ("m.obj", random_obj(&mut rng).into_bytes()),
            1 => ("m.obj", mutate(&mut rng, &flag).into_bytes()),
            _ => {
                // The GLB with bytes changed, cut short, or a chunk length made up.
                let mut b = glb.to_vec();
                for _ in 0..1 + rng.below(8) {
                    let k = rng.below(b.len());
                    b[k] = rng.next() as u8;
                }
                if rng.below(4) == 0 {
                    b.truncate(rng.below(b.len()));
                }
                ("m.glb", b)
            }
        };
        std::fs::write(dir.join(file), &bytes).unwrap_or_else(|e| panic!("{e}"));
        let text = format!("name = \"fuzz\"\n{}", random_mesh_body(&mut rng, file));
        let path = dir.join("scene.toml");
        let result = catch_unwind(AssertUnwindSafe(|| {
            hooke::scene::from_toml(&text, SceneOrigin::File(path.clone())).map(|scene| {
                if scene
                    .bodies
                    .iter()
                    .map(|b| b.mass_count_bound())
                    .sum::<u64>()
                    <= 200_000
                {
                    let model = hooke::model::build(&scene);
                    assert!(model.mass_count() > 0);
                    assert!(model.initial.x.iter().all(|p| p.is_finite()));
                    assert!(model.mass_kg.iter().all(|m| m.is_finite() && *m > 0.0));
                }
            })
        }));
        let text = format!("{text}\n{}", String::from_utf8_lossy(&bytes));
        if judged(i, result, &text) {
            accepted += 1;
        } else {
            rejected += 1;
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("{accepted} random meshes accepted, {rejected} rejected with one clear error");
    assert!(
        accepted > 300 && rejected > 300,
        "accepted {accepted}, rejected {rejected}"
    );
}

/// The memory a bad input may take on its way to a refusal or a run (none may abort or
/// exceed 2 GB).
const MEMORY_CAP: u64 = 2 << 30;

/// A scene whose extent is absurd gets no allocation that grows with it: a 64-mass cube at
/// spacing_m = 1e30 (whose ground grid, a line every 0.25 m, once asked for 103 GB and aborted)
/// or 1e7, and a mesh at scale 1e30, are refused for a reach f32 cannot hold, naming the field;
/// at 1e5 m (within reach) the cube runs, its ground grid bounded, and its recording is small.
#[test]
fn absurd_extents_are_refused_or_run_in_bounded_memory() {
    let dir = common::temp_dir("extent");
    let cube = |spacing: &str| {
        let path = dir.join(format!("cube-{spacing}.toml"));
        let text = format!(
            "name = \"cube\"\n[solver]\nintegrator = \"semi-implicit\"\nsubsteps = 10\n\
             [effects]\ngravity_m_per_s2 = [0.0, -9.81, 0.0]\n[effects.ground]\nheight_m = 0.0\n\
             stiffness_n_per_m = 1000.0\n[[bodies]]\nname = \"cube\"\ngrid = [4, 4, 4]\n\
             spacing_m = {spacing}\nmass_kg = 1.0\norigin_m = [0.0, 1.0, 0.0]\n\
             [bodies.springs]\nstructural = {{ stiffness_n_per_m = 100.0 }}\n"
        );
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{e}"));
        path
    };
    let refused = |path: &std::path::Path, field: &str| {
        let out = common::hooke_within_memory(&["check", path.to_str().unwrap_or("")], MEMORY_CAP);
        let err = common::text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{}: {err}", path.display());
        assert!(
            err.contains(field) && err.contains("beyond the 1e6 m") && !err.contains("panicked"),
            "{}: {err}",
            path.display()
        );
    };
    for spacing in ["1e30", "1e7"] {
        refused(&cube(spacing), "`bodies[0].spacing_m`");
    }
    let mesh = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/meshes/flag.obj");
    let flag = common::scene_variant(
        &dir,
        "flag",
        "flag-1e30.toml",
        &[("\"../meshes/flag.obj\"", &format!("{mesh:?}\nscale = 1e30"))],
    );
    refused(std::path::Path::new(&flag), "`bodies[0].scale`");
    let far = cube("1e5");
    let file = dir.join("far.rrd");
    let out = common::hooke_within_memory(
        &[
            "run",
            far.to_str().unwrap_or(""),
            "--backend",
            "cpu",
            "--frames",
            "2",
            "--save",
            file.to_str().unwrap_or(""),
        ],
        MEMORY_CAP,
    );
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    let bytes = std::fs::metadata(&file).map(|m| m.len()).unwrap_or(0);
    assert!(bytes > 0 && bytes < 1_000_000, "{bytes} bytes");
    common::verified_rrd(&file);
}

/// A gravity of 1e30 m/s² (also 1e25, on both backends) kept the masses finite on the ground
/// while the ledger booked infinite contact work: the run exited 0 with infinity and NaN in
/// `energy/...`. The watch stops it at the frame, naming the term, and the recording holds no
/// NaN or infinity.
#[test]
fn a_ledger_that_goes_non_finite_stops_the_run_and_never_reaches_the_recording() {
    let dir = common::temp_dir("ledger");
    let backends = common::backends();
    for g in ["1e30", "1e25"] {
        let scene = common::scene_variant(
            &dir,
            "jello",
            &format!("jello-g{g}.toml"),
            &[(
                "gravity_m_per_s2 = [0.0, -9.81, 0.0]",
                &format!("gravity_m_per_s2 = [0.0, -{g}, 0.0]"),
            )],
        );
        for backend in &backends {
            let file = dir.join(format!("g{g}-{backend}.rrd"));
            let out = common::hooke_within_memory(
                &[
                    "run",
                    &scene,
                    "--backend",
                    backend,
                    "--frames",
                    "10",
                    "--save",
                    file.to_str().unwrap_or(""),
                ],
                // Address space, not memory: lavapipe reserves more than it uses.
                MEMORY_CAP * 2,
            );
            let err = common::text(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{g} {backend}: {err}");
            assert!(
                err.contains("energy ledger went non-finite at frame")
                    && err.contains("energy/dissipated_contact"),
                "{g} {backend}: {err}"
            );
            // Rerun reads it whole, and it holds no NaN or infinity.
            common::verified_rrd(&file);
        }
    }
}

/// A 4 × 4 × 4 jello thrown into the ground at 1 000 m/s (its own step, 1/2400 s, carries it
/// 0.42 m a step through a 5 cm lattice) used to end flat: every mass put back at the contact's
/// allowed depth, all in one plane, for the rest of the run, exit 0. The run stops at the
/// impact, naming the speed and the step that keeps each step's sink within the contact, on
/// both backends. A start speed past the runaway limit (1e6 m/s) is refused before it steps.
#[test]
fn an_impact_too_fast_for_the_step_stops_the_run_instead_of_flattening_the_body() {
    let dir = common::temp_dir("impact");
    let thrown = |speed: &str| {
        common::scene_variant(
            &dir,
            "jello",
            &format!("jello-{speed}.toml"),
            &[
                ("grid = [10, 10, 10]", "grid = [4, 4, 4]"),
                (
                    "mass_kg = 1.0\n",
                    &format!("mass_kg = 1.0\nvelocity_m_per_s = [0.0, -{speed}, 0.0]\n"),
                ),
            ],
        )
    };
    let fast = thrown("1000");
    let backends = common::backends();
    for backend in backends {
        let out = common::hooke(&[
            "run",
            &fast,
            "--backend",
            backend,
            "--frames",
            "30",
            "--save",
            &dir.join(format!("fast-{backend}.rrd")).to_string_lossy(),
        ]);
        common::verified_rrd(&dir.join(format!("fast-{backend}.rrd")));
        let err = common::text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{backend}: {err}");
        assert!(
            err.contains("was too fast for the step")
                && err.contains("moved at about 1.000e3 m/s")
                && err.contains("--dt 2.500e-5"),
            "{backend}: {err}"
        );
    }
    let out = common::hooke(&["check", &thrown("1e6")]);
    let err = common::text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("`bodies[0].velocity_m_per_s`") && err.contains("runaway"),
        "{err}"
    );
}

/// A grid under the mass limit but beyond the machine's memory (8192 × 8192 with every spring
/// kind: about 112 GB) used to abort inside `model::build` under a 4 GB cap. It is refused
/// before anything is built, with the bytes it needs, what is available and how many masses
/// would fit; a scene that fits still runs under the same cap.
#[test]
fn a_scene_beyond_the_memory_at_hand_is_refused_before_it_is_built() {
    let dir = common::temp_dir("memory");
    let cloth = |n: u32| {
        common::scene_variant(
            &dir,
            "cloth",
            &format!("cloth-{n}.toml"),
            &[
                ("grid = [32, 32]", &format!("grid = [{n}, {n}]")),
                ("spacing_m = 0.05", "spacing_m = 0.0001"),
            ],
        )
    };
    let huge = cloth(8192);
    for backend in ["cpu", "gpu"] {
        let out =
            common::hooke_within_memory(&["check", &huge, "--backend", backend], MEMORY_CAP * 2);
        let err = common::text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{backend}: {err}");
        assert!(
            err.contains("needs about")
                && err.contains("67108864 masses")
                && err.contains("is available here")
                && err.contains("of those masses fit"),
            "{backend}: {err}"
        );
    }
    let out = common::hooke_within_memory(
        &[
            "run",
            &cloth(300),
            "--backend",
            "cpu",
            "--frames",
            "1",
            "--integrator",
            "implicit",
            "--dt",
            "0.016666667",
            "--save",
            &dir.join("fits.rrd").to_string_lossy(),
        ],
        MEMORY_CAP * 2,
    );
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    common::verified_rrd(&dir.join("fits.rrd"));
}

/// A body that starts 5 m under the ground, or wholly inside a sphere, used to run with no word
/// (7.6e5 J of contact energy in its first frame). It is refused before stepping, naming the
/// body; a body resting on the ground, as every built-in scene's does, is not.
#[test]
fn a_body_that_starts_buried_is_refused_before_it_steps() {
    let dir = common::temp_dir("buried");
    for (name, from, to, says) in [
        (
            "under",
            "origin_m = [-0.2, 0.5, -0.2]",
            "origin_m = [-0.2, -5.0, -0.2]",
            "body 'jello' starts 4.",
        ),
        (
            "inside",
            "[[bodies]]",
            "[[effects.spheres]]\ncenter_m = [0.0, 0.7, 0.0]\nradius_m = 2.0\nstiffness_n_per_m = 100.0\n\n[[bodies]]",
            "body 'jello' starts wholly inside collider 0",
        ),
    ] {
        let path = common::scene_variant(&dir, "jello", &format!("{name}.toml"), &[(from, to)]);
        let out = common::hooke(&["check", &path]);
        let err = common::text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{name}: {err}");
        assert!(err.contains(says), "{name}: {err}");
    }
    for b in hooke::scene::BUILT_IN {
        let out = common::hooke(&["check", b.name, "--backend", "cpu"]);
        assert!(
            out.status.success(),
            "{}: {}",
            b.name,
            common::text(&out.stderr)
        );
    }
}
