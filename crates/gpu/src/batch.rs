//! Batches: the simulations of one batch group that run at the same time share kernel launches.
//!
//! One repose test of a few thousand spheres cannot fill a GPU: a step is a dozen launches with
//! little work each. A study's runner starts a stage's runs on as many threads as `--jobs` says,
//! each with its own [`crate::GpuStages`] joined to the stage's group
//! (`dem::sim::in_batch_group`). When a simulation hands a segment to the device, its thread packs
//! it (a [`World`]) and waits here; once every member of the group is waiting (or a member's
//! thread is itself waiting for another member, or [`STRAGGLER_WAIT`] has passed since the first
//! arrival), the thread that completes the set runs all the waiting worlds side by side in one run
//! of launches, each for its own number of steps, and hands each thread its own end. Members that
//! arrive while a batch runs wait for the next. A world's result does not depend on its
//! neighbours (see [`crate::resident`]), so batching changes speed, not answers.

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard, OnceLock};
use std::thread::ThreadId;
use std::time::{Duration, Instant};

use dem::sim::SegmentEnd;

use crate::resident::world::World;
use crate::GpuStages;

/// How long the first arrival waits for members that do not come (a member busy with long host
/// work); the batch then runs without them.
pub const STRAGGLER_WAIT: Duration = Duration::from_millis(500);

/// A back end's place in a batch group; leaving the group when dropped.
#[derive(Debug)]
pub(crate) struct Member {
    group: u64,
    id: u64,
}

impl Drop for Member {
    fn drop(&mut self) {
        coordinator().leave(self.group, self.id);
    }
}

/// Batches run so far in this process: runs of launches shared by more than one world, the
/// worlds in them, and the most worlds in one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BatchStats {
    pub batches: usize,
    pub worlds: usize,
    pub largest: usize,
}

/// This process's batch counts.
pub fn batch_stats() -> BatchStats {
    let c = coordinator();
    BatchStats {
        batches: c.batches.load(Ordering::Relaxed),
        worlds: c.worlds.load(Ordering::Relaxed),
        largest: c.largest.load(Ordering::Relaxed),
    }
}

#[derive(Default)]
struct Group {
    /// Members alive, with the thread that last ran each.
    members: HashMap<u64, ThreadId>,
    waiting: Vec<(u64, World)>,
    finished: HashMap<u64, Option<SegmentEnd>>,
    running: bool,
    /// When the first of the waiting worlds arrived.
    since: Option<Instant>,
}

impl Group {
    fn ready(&self) -> bool {
        if self.running || self.waiting.is_empty() {
            return false;
        }
        if self.since.is_some_and(|s| s.elapsed() >= STRAGGLER_WAIT) {
            return true;
        }
        let ids: HashSet<u64> = self.waiting.iter().map(|(id, _)| *id).collect();
        let threads: HashSet<ThreadId> = ids.iter().map(|id| self.members[id]).collect();
        // A member whose thread waits for another member cannot come: it is not waited for.
        self.members
            .iter()
            .all(|(id, thread)| ids.contains(id) || threads.contains(thread))
    }
}

struct Coordinator {
    groups: Mutex<HashMap<u64, Group>>,
    changed: Condvar,
    next_member: AtomicU64,
    batches: AtomicUsize,
    worlds: AtomicUsize,
    largest: AtomicUsize,
}

fn coordinator() -> &'static Coordinator {
    static C: OnceLock<Coordinator> = OnceLock::new();
    C.get_or_init(|| Coordinator {
        groups: Mutex::new(HashMap::new()),
        changed: Condvar::new(),
        next_member: AtomicU64::new(1),
        batches: AtomicUsize::new(0),
        worlds: AtomicUsize::new(0),
        largest: AtomicUsize::new(0),
    })
}

impl Coordinator {
    fn lock(&self) -> MutexGuard<'_, HashMap<u64, Group>> {
        // Nothing panics while holding the lock, so a poisoned one is whole.
        self.groups.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn leave(&self, group: u64, id: u64) {
        let mut groups = self.lock();
        if let Some(g) = groups.get_mut(&group) {
            g.members.remove(&id);
            g.finished.remove(&id);
            g.waiting.retain(|(w, _)| *w != id);
            if g.members.is_empty() && !g.running {
                groups.remove(&group);
            }
        }
        self.changed.notify_all();
    }
}

/// Joins batch `group` (on this thread).
pub(crate) fn join(group: u64) -> Member {
    let c = coordinator();
    let id = c.next_member.fetch_add(1, Ordering::Relaxed);
    c.lock()
        .entry(group)
        .or_default()
        .members
        .insert(id, std::thread::current().id());
    Member { group, id }
}

/// Gives the worlds' ends to their members, or None each if the batch did not finish (a panic in
/// the run), so no member waits for ever.
struct Deliver<'a> {
    group: u64,
    ids: Vec<u64>,
    ends: Option<Vec<Option<SegmentEnd>>>,
    coordinator: &'a Coordinator,
}

impl Drop for Deliver<'_> {
    fn drop(&mut self) {
        let c = self.coordinator;
        let mut groups = c.lock();
        if let Some(g) = groups.get_mut(&self.group) {
            g.running = false;
            let ends = self.ends.take().unwrap_or_default();
            let mut ends = ends.into_iter();
            for id in &self.ids {
                let end = ends.next().flatten();
                if g.members.contains_key(id) {
                    g.finished.insert(*id, end);
                }
            }
            if !g.waiting.is_empty() {
                g.since = Some(Instant::now());
            }
            if g.members.is_empty() {
                groups.remove(&self.group);
            }
        }
        c.changed.notify_all();
    }
}

impl GpuStages {
    /// Runs `world` in its member's group: with the other members' worlds when they come.
    pub(crate) fn run_in_batch(&self, member: &Member, world: World) -> Option<SegmentEnd> {
        let c = coordinator();
        let (group, id) = (member.group, member.id);
        let mut groups = c.lock();
        {
            let g = groups.entry(group).or_default();
            g.members.insert(id, std::thread::current().id());
            g.waiting.push((id, world));
            g.since.get_or_insert_with(Instant::now);
        }
        c.changed.notify_all();
        loop {
            let g = groups.entry(group).or_default();
            if let Some(end) = g.finished.remove(&id) {
                return end;
            }
            if g.ready() {
                let (ids, worlds): (Vec<u64>, Vec<World>) =
                    std::mem::take(&mut g.waiting).into_iter().unzip();
                g.since = None;
                g.running = true;
                drop(groups);
                let mut deliver = Deliver {
                    group,
                    ids,
                    ends: None,
                    coordinator: c,
                };
                deliver.ends = Some(self.run_batch(&worlds));
                drop(deliver);
                groups = c.lock();
                continue;
            }
            let wait = match g.since {
                Some(s) if !g.running => STRAGGLER_WAIT.saturating_sub(s.elapsed()),
                _ => STRAGGLER_WAIT,
            };
            groups = c
                .changed
                .wait_timeout(groups, wait.max(Duration::from_millis(1)))
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }

    /// Runs worlds together; when they cannot run together (too large for one binding), each on
    /// its own.
    fn run_batch(&self, worlds: &[World]) -> Vec<Option<SegmentEnd>> {
        if worlds.len() > 1 {
            let c = coordinator();
            c.batches.fetch_add(1, Ordering::Relaxed);
            c.worlds.fetch_add(worlds.len(), Ordering::Relaxed);
            c.largest.fetch_max(worlds.len(), Ordering::Relaxed);
            if let Some(ends) = self.run_worlds(worlds) {
                return ends.into_iter().map(Some).collect();
            }
        }
        worlds
            .iter()
            .map(|w| {
                self.run_worlds(std::slice::from_ref(w))
                    .and_then(|mut e| e.pop())
            })
            .collect()
    }
}
