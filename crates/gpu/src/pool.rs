//! Device buffers kept from one segment for the next. A segment's try makes some forty buffers
//! (and, in a long segment, two sets of copies of those its end reads), and the next segment of the same
//! worlds needs the same sizes again: rather than free them and allocate anew, the context keeps
//! the buffers of the last try that finished, and the next try takes those of the size and usage
//! it asks for and writes its data over them whole (`GpuContext::storage_with`), or uses them as
//! copies that are written before they are read (`GpuContext::scratch`). Only the last finished
//! try's buffers are kept, so what the pool holds is at most one try's memory (held by the
//! context until its next segment); it is freed first where a try or its copies would not fit
//! the memory budget beside it, and where the driver runs out of memory with it held.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

#[derive(Default)]
pub(crate) struct Pool {
    kept: Mutex<Vec<wgpu::Buffer>>,
    /// Buffers taken from the pool rather than made, since the context was made.
    reused: AtomicU64,
}

impl Pool {
    fn kept(&self) -> std::sync::MutexGuard<'_, Vec<wgpu::Buffer>> {
        self.kept.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A kept buffer of exactly `size` bytes and `usage`, taken out of the pool.
    pub fn take(&self, size: u64, usage: wgpu::BufferUsages) -> Option<wgpu::Buffer> {
        let mut kept = self.kept();
        let at = kept
            .iter()
            .position(|b| b.size() == size && b.usage() == usage)?;
        self.reused.fetch_add(1, Ordering::Relaxed);
        Some(kept.swap_remove(at))
    }

    /// Keeps `buffers` for the next try, in place of those kept before (freed).
    pub fn keep(&self, buffers: Vec<wgpu::Buffer>) {
        *self.kept() = buffers;
    }

    /// Frees the kept buffers unless a try of `needed` bytes fits the `budget` beside them.
    pub fn make_room(&self, needed: u64, budget: u64) {
        let mut kept = self.kept();
        let held: u64 = kept.iter().map(|b| b.size()).sum();
        if needed.saturating_add(held) > budget {
            kept.clear();
        }
    }

    /// Frees every kept buffer; whether there were any.
    pub fn clear(&self) -> bool {
        let mut kept = self.kept();
        let held = !kept.is_empty();
        kept.clear();
        held
    }

    /// Buffers taken from the pool rather than made so far.
    pub fn reused(&self) -> u64 {
        self.reused.load(Ordering::Relaxed)
    }
}
