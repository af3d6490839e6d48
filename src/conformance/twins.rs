//! Every GPU kernel's CPU namesake exists: the build fails otherwise. The kernel table
//! (`gpu/kernel_table.rs`) names each namesake by its path under `cpu/`; this check sits above both
//! backends, so that the GPU backend imports nothing from the CPU backend.

macro_rules! check_twins {
    ($(
        $(#[doc = $doc:literal])*
        $variant:ident = $entry:ident in $program:ident { $($row:tt)* }
    )*) => {
        $(check_twins!(@find $entry $($row)*);)*
    };
    // Naming the namesake fails the build when it is missing.
    (@find $entry:ident cpu: ($($module:ident)::+) $($rest:tt)*) => {
        const _: () = {
            let _ = crate::cpu::$($module::)+$entry;
        };
    };
    // A reason instead of a namesake.
    (@find $entry:ident cpu: $reason:literal $($rest:tt)*) => {};
    (@find $entry:ident $skip:tt $($rest:tt)*) => {
        check_twins!(@find $entry $($rest)*);
    };
}

crate::gpu::kernel_table::kernel_table!(check_twins);
