//! How a failed write of a `.rrd` file is told: what failed, what the file still holds, and
//! what would let the next run through.

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

use rerun::external::re_log_encoding::EncodeError;

/// Why the file stopped growing, and how much of the run it holds.
#[derive(Debug, Clone)]
pub struct WriteFailure {
    pub path: PathBuf,
    /// What failed: the operating system's error ("No space left on device (os error 28)"), or
    /// the encoder's.
    pub cause: WriteCause,
    /// What would let the next run through.
    pub advice: &'static str,
    /// Frames 0 to this one are complete in the file; `None` when not even frame 0 is.
    pub last_complete_frame: Option<i64>,
    /// Size of the file as left: whole messages only.
    pub bytes_kept: u64,
    /// The frames are all there, only the index at the end of the file could not be written.
    pub at_index: bool,
}

impl std::fmt::Display for WriteFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let kept = match self.last_complete_frame {
            Some(n) => format!(
                "frames 0 to {n} ({} frames, {}) are complete in the file and readable",
                n + 1,
                human_bytes(self.bytes_kept)
            ),
            None => "no frame reached the file".to_owned(),
        };
        if self.at_index {
            write!(
                f,
                "{} writing the index at the end of {}: {kept}, only without an index \
                 (Rerun reads it all the same)",
                self.cause,
                self.path.display()
            )
        } else {
            let after = self.last_complete_frame.map_or_else(
                || "before frame 0".to_owned(),
                |n| format!("after frame {n}"),
            );
            write!(
                f,
                "{} writing {} {after}; the simulation stopped there: {kept}. {}",
                self.cause,
                self.path.display(),
                self.advice
            )
        }
    }
}

/// "1.2 MB": sizes in messages, in decimal units as `df -H` prints them.
pub fn human_bytes(bytes: u64) -> String {
    let b = bytes as f64;
    match bytes {
        0..1_000 => format!("{bytes} B"),
        1_000..1_000_000 => format!("{:.1} kB", b / 1e3),
        1_000_000..1_000_000_000 => format!("{:.1} MB", b / 1e6),
        _ => format!("{:.2} GB", b / 1e9),
    }
}

/// Why a write failed, shared by every copy of the failure.
#[derive(Debug, Clone)]
pub struct WriteCause(Arc<EncodeError>);

impl fmt::Display for WriteCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0.as_ref() {
            EncodeError::Write(io) => write!(f, "{io}"),
            other => write!(f, "encoding a message failed ({other})"),
        }
    }
}

impl std::error::Error for WriteCause {}

pub(super) fn cause(e: EncodeError) -> WriteCause {
    WriteCause(Arc::new(e))
}

/// What to do about a failed write, from the operating system's error number.
pub(super) fn advice(e: &EncodeError) -> &'static str {
    let code = match e {
        EncodeError::Write(io) => io.raw_os_error(),
        _ => None,
    };
    match code {
        Some(libc::ENOSPC) | Some(libc::EDQUOT) => {
            "Free some space, or record elsewhere with --save FILE (or fewer --frames)"
        }
        Some(libc::EFBIG) => {
            "The file-size limit (ulimit -f) allows no more: raise it, or record fewer --frames"
        }
        _ => "Record elsewhere with --save FILE",
    }
}
