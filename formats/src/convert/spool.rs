//! Sequential inputs copied to disk so they can be read in any order.

use crate::reader::{Access, At, CResult, InputInfo, SliceReader};
use crate::slice::SliceData;
use std::io::Write;
use std::path::Path;

/// The start of the names of spooled copies (`.vol-convert-spool.XXXXXX`).
pub(crate) const SPOOL_PREFIX: &str = ".vol-convert-spool.";

/// A sequential input copied to a temporary file first, so that it can be
/// read in any order (for flipping z) or twice (for an automatic window).
/// Memory stays bounded: the copy lives on disk.
pub struct Spooled {
    info: InputInfo,
    inner_bytes: u64,
    file: tempfile::NamedTempFile,
}

impl Spooled {
    /// Copy all slices of `inner` (in order) to a temporary file in `dir`,
    /// calling `each` with every slice as it passes.
    pub fn new(
        inner: &dyn SliceReader,
        dir: &Path,
        mut each: impl FnMut(&SliceData),
    ) -> CResult<Spooled> {
        let info = inner.info().clone();
        // Locked while in use: a killed conversion's copy is removed by the
        // next one that spools in `dir`.
        let mut file = crate::output::temp_file_in(dir, SPOOL_PREFIX, "").at(dir)?;
        {
            let mut w = std::io::BufWriter::with_capacity(1 << 20, file.as_file_mut());
            for z in 0..info.dims.z {
                let s = inner.read_slice(z)?;
                each(&s);
                w.write_all(s.as_bytes()).at(dir)?;
            }
            w.flush().at(dir)?;
        }
        inner.finish()?;
        Ok(Spooled {
            inner_bytes: inner.bytes_in(),
            info,
            file,
        })
    }
}

impl SliceReader for Spooled {
    fn info(&self) -> &InputInfo {
        &self.info
    }
    fn access(&self) -> Access {
        Access::Random
    }
    fn read_slice_into(&self, z: u64, reuse: Option<SliceData>) -> CResult<SliceData> {
        let t = self.info.sample_type;
        let n = self.info.dims.slice_len();
        crate::raw::read_typed(
            self.file.as_file(),
            t,
            z * n * t.size() as u64,
            n as usize,
            cfg!(target_endian = "big"),
            reuse,
        )
        .at(self.file.path())
    }
    fn bytes_in(&self) -> u64 {
        self.inner_bytes
    }
}
