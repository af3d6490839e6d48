//! What `gltf` 1.4 does not check before it reads, checked here (it panics, or allocates without
//! bound, on such files), and a last guard around the readers: a panic inside one becomes an
//! error naming the file, with no panic message printed.

use std::cell::Cell;
use std::sync::Once;

use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;

/// What is wrong with an accessor a mesh's triangles are read through.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AccessorProblem {
    #[error("it does not exist (the file has {count} accessors)")]
    Missing { count: usize },
    #[error("its {what} are {found}, where glTF asks for {wanted}")]
    WrongType {
        what: &'static str,
        found: String,
        wanted: &'static str,
    },
    #[error("it is sparse, which Hooke does not read")]
    Sparse,
    #[error("it names buffer view {view}, which does not exist")]
    NoView { view: usize },
    #[error("its {count} elements reach byte {end} of a buffer view {length} bytes long")]
    PastView { count: u64, end: u64, length: u64 },
    #[error("its buffer view reaches byte {end} of buffer {buffer}, which holds {length} bytes")]
    PastBuffer {
        buffer: usize,
        end: u64,
        length: u64,
    },
}

/// The accessors a primitive's positions and indices are read through, before `gltf` reads
/// them: an index past the accessors (validation indexes them unchecked), a float index type
/// (the reader reaches `unreachable!`), a sparse accessor, or elements past their buffer.
/// `buffers` are the buffers' bytes, or `None` before they are loaded (indices only).
pub fn check_accessors(
    json: &gltf::json::Root,
    buffers: Option<&[Vec<u8>]>,
) -> Result<(), (usize, usize, AccessorProblem)> {
    let count = json.accessors.len();
    let position = Checked::Valid(gltf::Semantic::Positions);
    for (m, mesh) in json.meshes.iter().enumerate() {
        for p in &mesh.primitives {
            let used = [
                p.attributes.get(&position).map(|a| (a.value(), true)),
                p.indices.map(|a| (a.value(), false)),
            ];
            for (a, is_position) in used.into_iter().flatten() {
                let Some(accessor) = json.accessors.get(a) else {
                    return Err((m, a, AccessorProblem::Missing { count }));
                };
                if let Some(buffers) = buffers {
                    accessor_fits(json, accessor, is_position, buffers).map_err(|e| (m, a, e))?;
                }
            }
        }
    }
    Ok(())
}

fn accessor_fits(
    json: &gltf::json::Root,
    a: &gltf::json::Accessor,
    is_position: bool,
    buffers: &[Vec<u8>],
) -> Result<(), AccessorProblem> {
    let component = match a.component_type {
        Checked::Valid(c) => c.0,
        Checked::Invalid => return Err(wrong("component type", "invalid", is_position)),
    };
    let kind = match a.type_ {
        Checked::Valid(t) => t,
        Checked::Invalid => return Err(wrong("element type", "invalid", is_position)),
    };
    let (components, wanted_kind) = match is_position {
        true => (3, Type::Vec3),
        false => (1, Type::Scalar),
    };
    if kind != wanted_kind {
        return Err(wrong("elements", &format!("{kind:?}"), is_position));
    }
    let component_ok = match is_position {
        true => component == ComponentType::F32,
        false => matches!(
            component,
            ComponentType::U8 | ComponentType::U16 | ComponentType::U32
        ),
    };
    if !component_ok {
        return Err(wrong("components", &format!("{component:?}"), is_position));
    }
    if a.sparse.is_some() {
        return Err(AccessorProblem::Sparse);
    }
    let Some(view) = a.buffer_view else {
        // No view: all zeros, of the accessor's count (gltf reads none).
        return Ok(());
    };
    let Some(v) = json.buffer_views.get(view.value()) else {
        return Err(AccessorProblem::NoView { view: view.value() });
    };
    let element = component.size() as u64 * components;
    let stride = v.byte_stride.map_or(element, |s| s.0 as u64);
    let count = a.count.0;
    let offset = a.byte_offset.map_or(0, |o| o.0);
    let end = match count {
        0 => offset,
        n => (n - 1)
            .checked_mul(stride)
            .and_then(|b| b.checked_add(offset + element))
            .unwrap_or(u64::MAX),
    };
    let length = v.byte_length.0;
    if end > length {
        return Err(AccessorProblem::PastView { count, end, length });
    }
    let buffer = v.buffer.value();
    let view_end = v.byte_offset.map_or(0, |o| o.0).saturating_add(length);
    let held = buffers.get(buffer).map_or(0, |b| b.len() as u64);
    if view_end > held {
        return Err(AccessorProblem::PastBuffer {
            buffer,
            end: view_end,
            length: held,
        });
    }
    Ok(())
}

fn wrong(what: &'static str, found: &str, is_position: bool) -> AccessorProblem {
    AccessorProblem::WrongType {
        what,
        found: found.to_owned(),
        wanted: match is_position {
            true => "positions of three f32 (VEC3, FLOAT)",
            false => "indices of one unsigned integer (SCALAR; UNSIGNED_BYTE, _SHORT or _INT)",
        },
    }
}

/// The first node that is its own ancestor among the scene's `roots` (`children` of each node by
/// index), or a node reached twice: glTF's nodes form trees, and walking a cycle never ends.
pub fn node_cycle(children: &[Vec<usize>], roots: &[usize]) -> Option<usize> {
    let mut seen = vec![false; children.len()];
    let mut stack: Vec<usize> = roots.to_vec();
    while let Some(n) = stack.pop() {
        let slot = seen.get_mut(n)?;
        if *slot {
            return Some(n);
        }
        *slot = true;
        stack.extend(children.get(n).into_iter().flatten().copied());
    }
    None
}

thread_local! {
    static QUIET: Cell<bool> = const { Cell::new(false) };
}

/// `read` with a panic inside it caught and given back as `None`, its message not printed (the
/// caller names the file). Panics elsewhere print as before.
pub fn without_panics<T>(read: impl FnOnce() -> T) -> Option<T> {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let before = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(Cell::get) {
                before(info);
            }
        }));
    });
    QUIET.with(|q| q.set(true));
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(read));
    QUIET.with(|q| q.set(false));
    out.ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cycle_of_nodes_is_found_and_a_tree_is_not() {
        assert_eq!(node_cycle(&[vec![1], vec![0]], &[0]), Some(0));
        assert_eq!(node_cycle(&[vec![1, 2], vec![], vec![]], &[0]), None);
        assert_eq!(node_cycle(&[vec![1], vec![2], vec![1]], &[0]), Some(1));
        // A node index past the nodes stops the walk (gltf's validation names it).
        assert_eq!(node_cycle(&[vec![5]], &[0]), None);
    }

    #[test]
    fn a_panic_in_a_reader_is_caught_quietly() {
        assert_eq!(without_panics(|| 3), Some(3));
        let caught: Option<()> = without_panics(|| panic!("inside a reader"));
        assert_eq!(caught, None);
    }
}
