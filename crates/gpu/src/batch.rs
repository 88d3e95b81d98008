//! Batches: the simulations of one batch group that run at the same time share kernel launches.
//!
//! One repose test of a few thousand spheres cannot fill a GPU: a step is a dozen launches with
//! little work each. A study's runner starts a stage's runs on as many threads as `--jobs` says,
//! each with its own [`crate::GpuStages`] joined to the stage's group
//! (`dem::sim::in_batch_group`). When a simulation hands a segment to the device, its thread packs
//! it (a [`World`]) and waits here; once every member of the group is waiting (or a member's
//! thread is itself waiting for another member, or a straggler wait has passed since the first
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
use crate::resident::Declined;
use crate::GpuStages;

/// Longest wait of the first arrival for members that do not come (a member busy with host work:
/// building its scene, stepping on its own after a declined segment, measuring); the batch then
/// runs without them. The wait is a quarter of the group's last batch, within these bounds, so
/// that stragglers cost at most about a quarter of the device's time.
pub const STRAGGLER_WAIT: Duration = Duration::from_millis(500);
const SHORTEST_WAIT: Duration = Duration::from_millis(5);

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
/// worlds in them, the most worlds in one, sets of worlds that could not run together (then
/// halved until they could, or run alone), sets packed into several batches because together they
/// needed more device memory than the context's budget ([`crate::GpuContext::memory_budget`]), and
/// the most device memory a batch that ran took, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BatchStats {
    pub batches: usize,
    pub worlds: usize,
    pub largest: usize,
    pub split: usize,
    pub packed: usize,
    pub most_bytes: u64,
}

/// This process's batch counts.
pub fn batch_stats() -> BatchStats {
    let c = coordinator();
    BatchStats {
        batches: c.batches.load(Ordering::Relaxed),
        worlds: c.worlds.load(Ordering::Relaxed),
        largest: c.largest.load(Ordering::Relaxed),
        split: c.split.load(Ordering::Relaxed),
        packed: c.packed.load(Ordering::Relaxed),
        most_bytes: c.most_bytes.load(Ordering::Relaxed),
    }
}

/// Notes the device memory a batch of `worlds` worlds took (`resident::run`).
pub(crate) fn note_bytes(worlds: usize, bytes: u64) {
    if worlds > 1 {
        coordinator().most_bytes.fetch_max(bytes, Ordering::Relaxed);
    }
}

/// Consecutive groups of `worlds` that fit `room` bytes each, where all of them together need
/// `needed`: each world's share of `needed` is its share of the particles (the buffers are
/// mostly per particle and per pair slot), and a world whose share alone passes `room` is a group
/// of its own. With `needed` over `room` there are at least two groups.
fn pack(worlds: &[World], needed: u64, room: u64) -> Vec<std::ops::Range<usize>> {
    let total: usize = worlds.iter().map(|w| w.n.max(1)).sum();
    let mut groups = Vec::new();
    let (mut first, mut taken) = (0, 0.0);
    for (k, w) in worlds.iter().enumerate() {
        let share = needed as f64 * w.n.max(1) as f64 / total as f64;
        if k > first && taken + share > room as f64 {
            groups.push(first..k);
            (first, taken) = (k, 0.0);
        }
        taken += share;
    }
    groups.push(first..worlds.len());
    groups
}

/// A world handed in: its ticket (one per hand-in, so that clones of one back end sharing a
/// member cannot take each other's ends), its member, the world.
struct Waiting {
    ticket: u64,
    member: u64,
    world: World,
}

#[derive(Default)]
struct Group {
    /// Members alive, with the thread that last ran each.
    members: HashMap<u64, ThreadId>,
    waiting: Vec<Waiting>,
    finished: HashMap<u64, Option<SegmentEnd>>,
    running: bool,
    /// When the first of the waiting worlds arrived.
    since: Option<Instant>,
    /// How long the group's last batch ran.
    last_run: Option<Duration>,
}

impl Group {
    /// How long a first arrival waits for the others.
    fn straggler_wait(&self) -> Duration {
        self.last_run.map_or(STRAGGLER_WAIT, |t| {
            (t / 4).clamp(SHORTEST_WAIT, STRAGGLER_WAIT)
        })
    }

    fn ready(&self) -> bool {
        if self.running || self.waiting.is_empty() {
            return false;
        }
        if self
            .since
            .is_some_and(|s| s.elapsed() >= self.straggler_wait())
        {
            return true;
        }
        let ids: HashSet<u64> = self.waiting.iter().map(|w| w.member).collect();
        let threads: HashSet<ThreadId> = ids
            .iter()
            .filter_map(|id| self.members.get(id))
            .copied()
            .collect();
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
    split: AtomicUsize,
    packed: AtomicUsize,
    most_bytes: AtomicU64,
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
        split: AtomicUsize::new(0),
        packed: AtomicUsize::new(0),
        most_bytes: AtomicU64::new(0),
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
            g.waiting.retain(|w| w.member != id);
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

/// Gives the worlds' ends to their tickets, or None each if the batch did not finish (a panic in
/// the run), so no member waits for ever.
struct Deliver<'a> {
    group: u64,
    tickets: Vec<u64>,
    ends: Option<Vec<Option<SegmentEnd>>>,
    started: Instant,
    coordinator: &'a Coordinator,
}

impl Drop for Deliver<'_> {
    fn drop(&mut self) {
        let c = self.coordinator;
        let mut groups = c.lock();
        if let Some(g) = groups.get_mut(&self.group) {
            g.running = false;
            g.last_run = Some(self.started.elapsed());
            let ends = self.ends.take().unwrap_or_default();
            let mut ends = ends.into_iter();
            for ticket in &self.tickets {
                g.finished.insert(*ticket, ends.next().flatten());
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
        let ticket = c.next_member.fetch_add(1, Ordering::Relaxed);
        let mut groups = c.lock();
        {
            let g = groups.entry(group).or_default();
            g.members.insert(id, std::thread::current().id());
            g.waiting.push(Waiting {
                ticket,
                member: id,
                world,
            });
            g.since.get_or_insert_with(Instant::now);
        }
        c.changed.notify_all();
        loop {
            let g = groups.entry(group).or_default();
            if let Some(end) = g.finished.remove(&ticket) {
                return end;
            }
            if g.ready() {
                let (tickets, worlds): (Vec<u64>, Vec<World>) = std::mem::take(&mut g.waiting)
                    .into_iter()
                    .map(|w| (w.ticket, w.world))
                    .unzip();
                g.since = None;
                g.running = true;
                drop(groups);
                let mut deliver = Deliver {
                    group,
                    tickets,
                    ends: None,
                    started: Instant::now(),
                    coordinator: c,
                };
                deliver.ends = Some(self.run_batch(&worlds));
                drop(deliver);
                groups = c.lock();
                continue;
            }
            let wait = match g.since {
                Some(s) if !g.running => g.straggler_wait().saturating_sub(s.elapsed()),
                _ => STRAGGLER_WAIT,
            };
            groups = c
                .changed
                .wait_timeout(groups, wait.max(Duration::from_millis(1)))
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }

    /// Runs worlds together; a set that needs more device memory than there is room for is
    /// packed into consecutive groups that fit ([`pack`]), a set that cannot run together for
    /// another reason (too large for one binding) is halved until it can, and a world that cannot
    /// run even alone is declined (it then steps stage by stage).
    fn run_batch(&self, worlds: &[World]) -> Vec<Option<SegmentEnd>> {
        let c = coordinator();
        match self.run_worlds(worlds) {
            Ok(ends) => {
                if worlds.len() > 1 {
                    c.batches.fetch_add(1, Ordering::Relaxed);
                    c.worlds.fetch_add(worlds.len(), Ordering::Relaxed);
                    c.largest.fetch_max(worlds.len(), Ordering::Relaxed);
                }
                ends.into_iter().map(Some).collect()
            }
            // A failed device: every world's steps go to the CPU, nothing left to split.
            Err(_) if self.ctx.failure().is_some() => worlds.iter().map(|_| None).collect(),
            Err(why) if worlds.len() == 1 => vec![self.decline(why.to_string())],
            Err(Declined::Memory { needed, room }) => {
                c.packed.fetch_add(1, Ordering::Relaxed);
                pack(worlds, needed, room)
                    .into_iter()
                    .flat_map(|group| self.run_batch(&worlds[group]))
                    .collect()
            }
            Err(_) => {
                c.split.fetch_add(1, Ordering::Relaxed);
                let (a, b) = worlds.split_at(worlds.len() / 2);
                let mut ends = self.run_batch(a);
                ends.extend(self.run_batch(b));
                ends
            }
        }
    }
}
