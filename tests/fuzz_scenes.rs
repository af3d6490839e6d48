//! A bounded fuzz test of the scene front end: thousands of mutated scene files (bytes flipped,
//! lines cut and spliced, absurd numbers, huge grids, deep nesting) must each give a scene or
//! one clear error, never a panic, and a scene that validates must build its model. The mutator
//! is a fixed-seed xorshift, so a failure reproduces exactly; CI runs it in a few seconds.

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
                let masses: u64 = scene
                    .bodies
                    .iter()
                    .map(|b| b.grid.iter().map(|&n| u64::from(n)).product::<u64>())
                    .sum();
                if masses <= 200_000 {
                    let model = hooke::model::build(&scene);
                    assert_eq!(model.mass_count() as u64, masses);
                }
            })
        }));
        match result {
            Ok(Ok(())) => accepted += 1,
            Ok(Err(e)) => {
                let msg = e.to_string();
                assert!(
                    !msg.is_empty() && !msg.contains('\n'),
                    "case {i}: error not one line: {msg:?}\n{text}"
                );
                rejected += 1;
            }
            Err(_) => panic!("case {i} panicked on:\n{text}"),
        }
    }
    // Both paths were exercised.
    eprintln!("{accepted} mutated scenes accepted, {rejected} rejected with one clear error");
    assert!(
        accepted > 500 && rejected > 5000,
        "accepted {accepted}, rejected {rejected}"
    );
}
