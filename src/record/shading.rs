//! How a surface is lit in the recording: area-weighted vertex normals, a key and a fill light
//! with ambient, and each strain colour shaded in linear light (sRGB converted through tables).

use glam::Vec3;

/// Area-weighted vertex normals of `triangles` (unit length; zero where a vertex has none).
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]], out: &mut Vec<Vec3>) {
    out.clear();
    out.resize(positions.len(), Vec3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        // |cross| is twice the area: larger triangles weigh more.
        let n = (b - a).cross(c - a);
        for v in t {
            out[*v as usize] += n;
        }
    }
    for n in out.iter_mut() {
        *n = n.normalize_or_zero();
    }
}

/// The viewer's mesh lighting (Rerun 0.36, `simple_lighting` in re_renderer's shaders): an
/// ambient 0.2, a key light along (1, 2, 3) and a fill light at half strength along
/// (−1, −3, −5), fixed in the world. A sheet is lit on whichever side faces the key light, as a
/// double-sided surface is; a zero normal (a vertex with no triangle) is left unlit.
pub fn shade(normal: Vec3, two_sided: bool) -> f32 {
    if normal == Vec3::ZERO {
        return 1.0;
    }
    let key = Vec3::new(1.0, 2.0, 3.0).normalize();
    let fill = Vec3::new(-1.0, -3.0, -5.0).normalize();
    let n = if two_sided && normal.dot(key) < 0.0 {
        -normal
    } else {
        normal
    };
    (0.2 + n.dot(key).max(0.0) + 0.5 * n.dot(fill).max(0.0)).clamp(0.0, 1.0)
}

/// An sRGB colour lit by `shade` as the viewer lights it: in linear light, then back to sRGB
/// (through lookup tables, within one level of 255 of the exact conversion: a frame of
/// cloth-256 shades 65 536 vertices).
pub fn shaded(srgb: [u8; 3], shade: f32) -> [u8; 3] {
    let t = tables();
    srgb.map(|c| {
        let lin = t.to_linear[usize::from(c)] * shade.clamp(0.0, 1.0);
        t.to_srgb[(lin * (SRGB_STEPS - 1) as f32).round() as usize]
    })
}

const SRGB_STEPS: usize = 4096;

struct Tables {
    to_linear: [f32; 256],
    to_srgb: Vec<u8>,
}

fn tables() -> &'static Tables {
    static TABLES: std::sync::OnceLock<Tables> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| Tables {
        to_linear: std::array::from_fn(|c| linear_from_srgb(c as f32 / 255.0)),
        to_srgb: (0..SRGB_STEPS)
            .map(|i| {
                let lin = i as f32 / (SRGB_STEPS - 1) as f32;
                (srgb_from_linear(lin) * 255.0).round().clamp(0.0, 255.0) as u8
            })
            .collect(),
    })
}

fn linear_from_srgb(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn srgb_from_linear(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shading_is_full_towards_the_key_light_and_ambient_away_from_both() {
        let key = Vec3::new(1.0, 2.0, 3.0).normalize();
        assert_eq!(shade(key, false), 1.0);
        // Perpendicular to both lights: ambient only.
        let away = Vec3::new(1.0, 2.0, 3.0).cross(Vec3::new(-1.0, -3.0, -5.0));
        assert!((shade(away.normalize(), false) - 0.2).abs() < 1e-5);
        // A sheet's back is lit as its front; a block's is not.
        assert_eq!(shade(-key, true), 1.0);
        assert!(shade(-key, false) < 0.7);
    }

    #[test]
    fn shaded_keeps_a_colour_at_full_light_and_darkens_it_in_shadow() {
        assert_eq!(shaded([180, 4, 38], 1.0), [180, 4, 38]);
        let dark = shaded([221, 221, 221], 0.2);
        assert!(dark[0] < 221 && dark[0] == dark[1] && dark[1] == dark[2]);
        assert_eq!(shaded([0, 0, 0], 0.5), [0, 0, 0]);
    }
}
