//! The WGSL files: the kernel files (`Program`), the libraries they import, and `common.wgsl`.
//! A kernel file names its libraries in a `// #import a b` line; a library names the bindings it
//! reads (`// #uses …`) and the functions its program must define (`// #calls …`), so that what
//! each piece relies on is written in it, and `shaders::missing` can check that a program
//! supplies it.

/// The structs, constants and helpers every program starts with.
pub const COMMON: &str = include_str!("../../shaders/common.wgsl");

/// The libraries a kernel file may import, by name: functions over bindings their programs bind.
const LIBRARIES: [(&str, &str); 14] = [
    (
        "xpbd_project",
        include_str!("../../shaders/xpbd_project.wgsl"),
    ),
    ("mass_force", include_str!("../../shaders/mass_force.wgsl")),
    ("vbd_mass", include_str!("../../shaders/vbd_mass.wgsl")),
    (
        "neighbour_walk",
        include_str!("../../shaders/neighbour_walk.wgsl"),
    ),
    (
        "state_check",
        include_str!("../../shaders/state_check.wgsl"),
    ),
    (
        "system_blocks",
        include_str!("../../shaders/system_blocks.wgsl"),
    ),
    (
        "implicit_terms",
        include_str!("../../shaders/implicit_terms.wgsl"),
    ),
    (
        "spring_records",
        include_str!("../../shaders/spring_records.wgsl"),
    ),
    (
        "contact_projection",
        include_str!("../../shaders/contact_projection.wgsl"),
    ),
    ("fused_mass", include_str!("../../shaders/fused_mass.wgsl")),
    ("stage_pose", include_str!("../../shaders/stage_pose.wgsl")),
    ("stage_step", include_str!("../../shaders/stage_step.wgsl")),
    (
        "solver_sums",
        include_str!("../../shaders/solver_sums.wgsl"),
    ),
    (
        "implicit_group",
        include_str!("../../shaders/implicit_group.wgsl"),
    ),
];

/// The library named `name`, if there is one.
pub fn library(name: &str) -> Option<&'static str> {
    LIBRARIES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, text)| *text)
}

/// The words of every `// #name …` line of `text`.
pub fn directive<'a>(text: &'a str, name: &'a str) -> impl Iterator<Item = &'a str> + 'a {
    text.lines()
        .filter_map(move |l| {
            l.strip_prefix("// #")
                .and_then(|rest| rest.strip_prefix(name))
                .filter(|rest| rest.starts_with(' '))
        })
        .flat_map(str::split_whitespace)
}

/// A WGSL file of kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Program {
    Forces,
    Integrate,
    Collide,
    Reduce,
    Implicit,
    Multigrid,
    Springs,
    Grid,
    CollideMasses,
    Xpbd,
    XpbdSweeps,
    Vbd,
    VbdSweeps,
    Fused,
    FusedFrame,
}

impl Program {
    pub const ALL: [Program; 15] = [
        Program::Forces,
        Program::Integrate,
        Program::Collide,
        Program::Reduce,
        Program::Implicit,
        Program::Multigrid,
        Program::Springs,
        Program::Grid,
        Program::CollideMasses,
        Program::Xpbd,
        Program::XpbdSweeps,
        Program::Vbd,
        Program::VbdSweeps,
        Program::Fused,
        Program::FusedFrame,
    ];

    pub fn file(self) -> &'static str {
        self.file_and_text().0
    }

    /// The file's own text.
    pub fn text(self) -> &'static str {
        self.file_and_text().1
    }

    /// The libraries the file imports, in order.
    pub fn imports(self) -> impl Iterator<Item = &'static str> {
        directive(self.text(), "import")
    }

    fn file_and_text(self) -> (&'static str, &'static str) {
        macro_rules! file {
            ($name:literal) => {
                ($name, include_str!(concat!("../../shaders/", $name)))
            };
        }
        match self {
            Program::Forces => file!("forces.wgsl"),
            Program::Integrate => file!("integrate.wgsl"),
            Program::Collide => file!("collide.wgsl"),
            Program::Reduce => file!("reduce.wgsl"),
            Program::Implicit => file!("implicit.wgsl"),
            Program::Multigrid => file!("multigrid.wgsl"),
            Program::Springs => file!("springs.wgsl"),
            Program::Grid => file!("grid.wgsl"),
            Program::CollideMasses => file!("collide_masses.wgsl"),
            Program::Xpbd => file!("xpbd.wgsl"),
            Program::XpbdSweeps => file!("xpbd_sweeps.wgsl"),
            Program::Vbd => file!("vbd.wgsl"),
            Program::VbdSweeps => file!("vbd_sweeps.wgsl"),
            Program::Fused => file!("fused.wgsl"),
            Program::FusedFrame => file!("fused_frame.wgsl"),
        }
    }
}
