//! Every kernel's full WGSL source, composed in one place: the layout constants
//! ([`layout::wgsl_constants`]), `vector.wgsl`, then the shared parts the kernel uses and its own
//! file. The context compiles exactly these sources, and the tests below parse and validate
//! them with naga (no device needed), so a kernel that does not compile fails `cargo test`
//! anywhere, not only where a GPU is.

use crate::layout;

const VECTOR: &str = include_str!("wgsl/vector.wgsl");
/// The stage kernels' accessors; needs `state`, `props`, `params` and `counts` bound.
const COMMON: &str = include_str!("wgsl/common.wgsl");
const SPIN: &str = include_str!("wgsl/spin.wgsl");
/// The second half kick of a particle (after SPIN and STATE_WRITES; `state` bound read_write).
const HALF_KICK: &str = include_str!("wgsl/half_kick.wgsl");
const CONTACT: &str = include_str!("wgsl/contact.wgsl");
/// A particle pair's contact (after COMMON and CONTACT; `ints` and `table` bound).
const PAIR_CONTACT: &str = include_str!("wgsl/pair_contact.wgsl");
/// `history` and `output` row accessors of the stage contact kernels (both bound).
const CONTACT_ROWS: &str = include_str!("wgsl/contact_rows.wgsl");
const ELEMENTS: &str = include_str!("wgsl/elements.wgsl");
/// Rigid clumps' quaternions, kicks and member placement (with `STATE_WRITES`); needs `bodies`,
/// `body_members`, `members`, `offsets` and the common buffers bound.
const RIGID: &str = include_str!("wgsl/bodies/rigid.wgsl");
/// `put3` into `state`, `load3` from `loads`, `put_load3` into `loads`: each needs its buffer
/// bound (read_write to write).
const STATE_WRITES: &str = include_str!("wgsl/state_writes.wgsl");
const LOAD_READS: &str = include_str!("wgsl/load_reads.wgsl");
const LOAD_WRITES: &str = include_str!("wgsl/load_writes.wgsl");
/// The segment kernels' list sentinel and cell hash.
const SHARED: &str = include_str!("wgsl/resident/shared.wgsl");
/// The pair histories' two halves; needs `ctrl`, `history_even` and `history_odd` bound.
const HISTORY_HALVES: &str = include_str!("wgsl/resident/history_halves.wgsl");

/// Every kernel: its name (the label the device reports) and its parts after the constants and
/// `vector.wgsl`, in order.
const KERNELS: &[(&str, &[&str])] = &[
    (
        "integrate",
        &[
            COMMON,
            SPIN,
            STATE_WRITES,
            LOAD_READS,
            include_str!("wgsl/integrate.wgsl"),
        ],
    ),
    (
        "pair_forces",
        &[
            COMMON,
            CONTACT,
            PAIR_CONTACT,
            CONTACT_ROWS,
            include_str!("wgsl/pair_forces.wgsl"),
        ],
    ),
    (
        "particle_sums",
        &[
            COMMON,
            SPIN,
            STATE_WRITES,
            LOAD_WRITES,
            HALF_KICK,
            include_str!("wgsl/particle_sums.wgsl"),
        ],
    ),
    (
        "wall_forces",
        &[
            COMMON,
            CONTACT,
            CONTACT_ROWS,
            ELEMENTS,
            include_str!("wgsl/wall_forces.wgsl"),
        ],
    ),
    ("begin", &[include_str!("wgsl/resident/begin.wgsl")]),
    ("check", &[COMMON, include_str!("wgsl/resident/check.wgsl")]),
    ("clear", &[include_str!("wgsl/resident/clear.wgsl")]),
    (
        "bin",
        &[COMMON, SHARED, include_str!("wgsl/resident/bin.wgsl")],
    ),
    (
        "build_pairs",
        &[
            COMMON,
            SHARED,
            HISTORY_HALVES,
            include_str!("wgsl/resident/build_pairs.wgsl"),
        ],
    ),
    (
        "build_walls",
        &[
            COMMON,
            SHARED,
            ELEMENTS,
            include_str!("wgsl/resident/build_walls.wgsl"),
        ],
    ),
    (
        "sort_reverse",
        &[include_str!("wgsl/resident/sort_reverse.wgsl")],
    ),
    (
        "commit",
        &[HISTORY_HALVES, include_str!("wgsl/resident/commit.wgsl")],
    ),
    (
        "particle_forces",
        &[
            COMMON,
            CONTACT,
            PAIR_CONTACT,
            LOAD_WRITES,
            HISTORY_HALVES,
            include_str!("wgsl/resident/particle_forces.wgsl"),
        ],
    ),
    (
        "kick",
        &[
            COMMON,
            SPIN,
            STATE_WRITES,
            LOAD_READS,
            HALF_KICK,
            include_str!("wgsl/resident/kick.wgsl"),
        ],
    ),
    (
        "geometry_loads",
        &[include_str!("wgsl/resident/geometry_loads.wgsl")],
    ),
    ("poses", &[include_str!("wgsl/resident/poses.wgsl")]),
    ("plan", &[include_str!("wgsl/resident/plan.wgsl")]),
    (
        "bond_forces",
        &[COMMON, include_str!("wgsl/bonds/bond_forces.wgsl")],
    ),
    (
        "bond_sums",
        &[
            COMMON,
            SPIN,
            STATE_WRITES,
            LOAD_READS,
            LOAD_WRITES,
            HALF_KICK,
            include_str!("wgsl/bonds/bond_sums.wgsl"),
        ],
    ),
    (
        "bodies_first",
        &[
            COMMON,
            STATE_WRITES,
            RIGID,
            include_str!("wgsl/bodies/bodies_first.wgsl"),
        ],
    ),
    (
        "bodies_last",
        &[
            COMMON,
            STATE_WRITES,
            LOAD_READS,
            RIGID,
            include_str!("wgsl/bodies/bodies_last.wgsl"),
        ],
    ),
];

/// Every kernel's name and full source, as the device compiles it.
pub(crate) fn kernel_sources() -> Vec<(&'static str, String)> {
    let constants = layout::wgsl_constants();
    KERNELS
        .iter()
        .map(|&(name, parts)| {
            let source = [constants.as_str(), VECTOR]
                .into_iter()
                .chain(parts.iter().copied())
                .collect::<Vec<_>>()
                .join("\n");
            (name, source)
        })
        .collect()
}

#[cfg(test)]
mod tests;
