//! The kinds of spring a grid body has, and which grid neighbours each kind joins. Both the
//! scene's validation (is a spring long enough in f32?) and the model builder read this table.

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SpringKindTag {
    Structural,
    Shear,
    Bending,
    /// Added by hand through [`ModelBuilder::spring`].
    Custom,
}

impl SpringKindTag {
    pub fn name(self) -> &'static str {
        match self {
            SpringKindTag::Structural => "structural",
            SpringKindTag::Shear => "shear",
            SpringKindTag::Bending => "bending",
            SpringKindTag::Custom => "custom",
        }
    }
}

/// Grid offsets of each spring kind, one per pair (the positive half of each direction).
pub fn kind_offsets(kind: SpringKindTag) -> &'static [[i32; 3]] {
    match kind {
        SpringKindTag::Structural => &[[1, 0, 0], [0, 1, 0], [0, 0, 1]],
        SpringKindTag::Shear => &[
            [1, 1, 0],
            [1, -1, 0],
            [1, 0, 1],
            [1, 0, -1],
            [0, 1, 1],
            [0, 1, -1],
            [1, 1, 1],
            [1, 1, -1],
            [1, -1, 1],
            [1, -1, -1],
        ],
        SpringKindTag::Bending => &[[2, 0, 0], [0, 2, 0], [0, 0, 2]],
        SpringKindTag::Custom => &[],
    }
}
