//! Colours: the strain scale of surfaces and springs, and the fixed colour of each plotted series
//! (each plot's legend and the `legend` document name each colour).

/// Colour of a strain value on the diverging scale: blue (compressed by `range` or more), light
/// grey (at rest), red (stretched by `range` or more).
pub fn strain_color(strain: f32, range: f32) -> [u8; 3] {
    const BLUE: [f32; 3] = [59.0, 76.0, 192.0];
    const GREY: [f32; 3] = [221.0, 221.0, 221.0];
    const RED: [f32; 3] = [180.0, 4.0, 38.0];
    let t = if strain.is_finite() {
        (strain / range).clamp(-1.0, 1.0)
    } else {
        1.0
    };
    let (end, w) = if t < 0.0 { (BLUE, -t) } else { (RED, t) };
    let mix = |i: usize| (GREY[i] + (end[i] - GREY[i]) * w).round() as u8;
    [mix(0), mix(1), mix(2)]
}

/// Colour of a distance to the reference on a sequential scale: dark blue-grey at 0, through
/// amber, to red at `range` or more (a non-finite gap is red).
pub fn gap_color(gap: f32, range: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 3] = [
        [70.0, 90.0, 130.0],
        [240.0, 190.0, 60.0],
        [200.0, 20.0, 30.0],
    ];
    let t = if gap.is_finite() {
        (gap / range).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let (a, b, w) = if t < 0.5 {
        (STOPS[0], STOPS[1], 2.0 * t)
    } else {
        (STOPS[1], STOPS[2], 2.0 * t - 1.0)
    };
    let mix = |i: usize| (a[i] + (b[i] - a[i]) * w).round() as u8;
    [mix(0), mix(1), mix(2)]
}

/// An sRGB triple as Rerun takes it.
pub(super) fn color([r, g, b]: [u8; 3]) -> rerun::Color {
    rerun::Color::from_rgb(r, g, b)
}

/// A series colour and its name in the legend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rgb {
    pub rgb: [u8; 3],
    pub name: &'static str,
}

const fn rgb(r: u8, g: u8, b: u8, name: &'static str) -> Rgb {
    Rgb {
        rgb: [r, g, b],
        name,
    }
}

// Series colours: distinct within each plot on the viewer's dark background.
pub(super) const ORANGE: Rgb = rgb(255, 160, 40, "orange");
pub(super) const GREEN: Rgb = rgb(90, 200, 90, "green");
pub(super) const BLUE: Rgb = rgb(80, 140, 255, "blue");
pub(super) const VIOLET: Rgb = rgb(170, 110, 230, "violet");
pub(super) const RED: Rgb = rgb(230, 60, 60, "red");
pub(super) const SALMON: Rgb = rgb(245, 150, 130, "salmon");
pub(super) const PINK: Rgb = rgb(240, 110, 200, "pink");
pub(super) const BROWN: Rgb = rgb(170, 120, 70, "brown");
pub(super) const DARK_RED: Rgb = rgb(140, 30, 40, "dark red");
pub(super) const CYAN: Rgb = rgb(60, 200, 220, "cyan");
pub(super) const WHITE: Rgb = rgb(235, 235, 235, "white");
/// Each entry of a comparison, in order (the reference first): its plot lines' colour.
pub(super) const ENTRY_COLORS: [Rgb; 6] = [WHITE, ORANGE, CYAN, VIOLET, GREEN, PINK];

// The yellow of `world/most_strained`, so that the strain plot and the marked spring match.
pub(super) const YELLOW: Rgb = rgb(255, 200, 0, "yellow");
/// Colliders: sand, off the strain scale (blue, grey, red) and the gap scale (blue-grey, amber,
/// red), so that a table or sphere showing through a cloth never reads as compressed springs
/// (the tablecloth's table, in the blue it once had, looked like compression).
pub(super) const COLLIDER: Rgb = rgb(176, 150, 104, "sand");
pub(super) const GREY: Rgb = rgb(150, 150, 150, "grey");
