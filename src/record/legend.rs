//! The `legend` text document: how surfaces and springs are coloured, what each body logs, and the
//! colour of each line in each plot (each plot names its lines in its own legend too).

use super::recorder::Recorder;
use super::series::{Plot, all_series};
use super::springs;

impl Recorder {
    pub(super) fn legend(&self) -> String {
        let r = self.strain_range;
        let mut bodies = String::new();
        for b in &self.bodies {
            let shown = b.lines.as_ref().map_or(0, |l| l.springs.len());
            let total = b.springs.len();
            let line = match (&b.surface, shown) {
                (Some(_), 0) if total > 0 && self.default_springs => format!(
                    "surface; its {total} springs are not logged (more than {} structural springs: \
                     add `--springs structural` or `--springs all`)",
                    springs::DEFAULT_MAX_SPRINGS
                ),
                (Some(_), _) => format!("surface, and {shown} of its {total} springs as lines"),
                (None, _) => format!("masses, and {shown} of its {total} springs as lines"),
            };
            bodies.push_str(&format!("- `{}`: {line}\n", b.name));
        }
        format!(
            "Surfaces and springs are coloured by strain (|x| − L) / L on a fixed scale: \
             **blue** −{r} or less (compressed), **light grey** 0 (at rest), **red** +{r} or more \
             (stretched); `[view] strain_range` sets it. A surface vertex takes the colour of its \
             most strained spring, lit as the viewer lights a mesh. Hover a spring for its strain, \
             kind and rest length (at the start, for plastic springs). Pins are black; the yellow \
             line marks the most strained spring of the kind the surfaces show (`stats/max_strain`). A torn spring is no longer \
             drawn, and its triangles leave the surface. Colliders are **sand**, off the strain \
             scale.\n\n{bodies}\n{}",
            self.plot_key()
        )
    }

    /// The colour of each line in each plot, as the plots' own legends name them.
    fn plot_key(&self) -> String {
        let mut key = String::from(
            "Plot lines (each plot's legend names them; click a name to hide its line):\n",
        );
        for plot in Plot::SHOWN {
            let lines: Vec<String> = all_series()
                .filter(|s| s.plot == plot && self.has(s.when))
                .map(|s| format!("{} **{}**", s.name.trim_start_matches("· "), s.color.name))
                .collect();
            key.push_str(&format!("- *{}*: {}\n", plot.title(), lines.join(", ")));
        }
        key
    }
}
