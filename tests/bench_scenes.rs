//! The benchmark scenes of `bench/scenes/` load, build, and are the cloth of NVIDIA Warp's
//! benchmark (warp/examples/benchmarks/benchmark_cloth.py): a d × d grid 0.1 m apart in the xz
//! plane, 0.1 kg per mass, the two corners of the first row pinned, stretch springs between
//! neighbours (2d(d − 1)), shear springs on both diagonals (2(d − 1)²) and bending springs two
//! apart (2d(d − 2)), all k = 1000 N/m and 10 N·s/m, stepped at 1/60 s in 16 substeps.

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/bench/scenes");

#[test]
fn warp_cloth_scenes_load_build_and_match_warps_cloth() {
    for d in [32usize, 64, 128] {
        let path = format!("{DIR}/warp-cloth-{d}.toml");
        let hooke::run::prepare::Planned {
            settings, model, ..
        } = hooke::run::prepare::planned(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
        assert!(
            (settings.dt_secs - 1.0 / 960.0).abs() < 1e-12,
            "{path}: dt {}",
            settings.dt_secs
        );
        assert_eq!(model.mass_count(), d * d, "{path}");
        assert!(
            model.mass_kg.iter().all(|m| (m - 0.1).abs() < 1e-6),
            "{path}: masses other than 0.1 kg"
        );
        // Row z = 0 is x = 0, 0.1, …; its first and last masses are the pins.
        let pinned: Vec<usize> = (0..d * d).filter(|&i| model.inv_mass[i] == 0.0).collect();
        assert_eq!(pinned.len(), 2, "{path}");
        let x = &model.initial.x;
        let far = 0.1 * (d - 1) as f32;
        for (i, at) in pinned.iter().zip([0.0, far]) {
            assert!(
                (x[*i].x - at).abs() < 1e-4 && x[*i].y == 0.0 && x[*i].z == 0.0,
                "{path}: pin at {:?}",
                x[*i]
            );
        }
        let (stretch, shear, bend) = (2 * d * (d - 1), 2 * (d - 1) * (d - 1), 2 * d * (d - 2));
        assert_eq!(model.spring_count(), stretch + shear + bend, "{path}");
        let rest = |r: f32| {
            model
                .springs
                .iter()
                .filter(|s| (s.rest_m - r).abs() < 1e-5)
                .count()
        };
        assert_eq!(rest(0.1), stretch, "{path}: stretch springs");
        assert_eq!(rest(0.1 * 2f32.sqrt()), shear, "{path}: shear springs");
        assert_eq!(rest(0.2), bend, "{path}: bending springs");
        assert!(
            model
                .springs
                .iter()
                .all(|s| s.stiffness_n_per_m == 1000.0 && s.damping_n_s_per_m == 10.0),
            "{path}: spring constants"
        );
    }
}
