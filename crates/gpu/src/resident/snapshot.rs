//! Copies of a segment's state taken on the device at the start of each chunk, so that a list
//! overflow ends the segment where the overflowing chunk began (the host goes on from there in a
//! new segment, with the room that was missing) instead of running the whole segment again.
//!
//! Two sets alternate between chunks: while the host reads one chunk's control words, the next
//! chunk, already submitted, takes its copy into the other set, so the set of the chunk that
//! overflowed is still whole when the host learns of it. The copies are of the buffers a
//! segment's end reads ([`super::run`]'s `kept`): the particles, their lists, histories (of the
//! pair histories, the half of the chunk's start) and wall outputs, what the end's `check` reads (drift, leaving the domain, wall row status), the control
//! words, and the bonds' and clumps' state. The first chunk takes none (an overflow there runs
//! the segment again).

/// The two sets of copies, and the step at which each was taken.
pub(super) struct Snapshots {
    sets: [Vec<wgpu::Buffer>; 2],
    taken_at: [usize; 2],
}

/// Segments of this many chunks or fewer run again from their start on an overflow: the copies
/// would cost more than they save.
pub(super) const FEWEST_CHUNKS: usize = 4;

impl Snapshots {
    /// The device memory the two sets of copies of `kept` take, in bytes.
    pub fn bytes(kept: &[&wgpu::Buffer]) -> u64 {
        2 * kept.iter().map(|b| b.size()).sum::<u64>()
    }

    /// Two sets of buffers the sizes of `kept` (from the context's pool where it has them).
    pub fn new(c: &crate::GpuContext, kept: &[&wgpu::Buffer]) -> Snapshots {
        let usage = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let set = || kept.iter().map(|b| c.scratch(b.size(), usage)).collect();
        Snapshots {
            sets: [set(), set()],
            taken_at: [0; 2],
        }
    }

    /// The buffers of both sets (for the context's pool when the segment is over).
    pub fn into_buffers(self) -> impl Iterator<Item = wgpu::Buffer> {
        self.sets.into_iter().flatten()
    }

    /// Encodes copies of `kept` into set `which` (before the chunk that starts at step `step`).
    pub fn take(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        kept: &[&wgpu::Buffer],
        which: usize,
        step: usize,
    ) {
        for (from, to) in kept.iter().zip(&self.sets[which]) {
            encoder.copy_buffer_to_buffer(from, 0, to, 0, from.size());
        }
        self.taken_at[which] = step;
    }

    /// The step at which set `which` was taken.
    pub fn taken_at(&self, which: usize) -> usize {
        self.taken_at[which]
    }

    /// Encodes copies of set `which` back into `kept`; the step at which it was taken.
    pub fn restore(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        kept: &[&wgpu::Buffer],
        which: usize,
    ) -> usize {
        for (from, to) in self.sets[which].iter().zip(kept) {
            encoder.copy_buffer_to_buffer(from, 0, to, 0, from.size());
        }
        self.taken_at[which]
    }
}
