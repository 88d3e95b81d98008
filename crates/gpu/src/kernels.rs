//! Every kernel's full WGSL source, composed in one place: the layout constants
//! ([`layout::wgsl_constants`]), `vector.wgsl`, then the shared parts the kernel uses and its own
//! file, then the bindings and accessors of the lists it may bind in parts ([`split_lists`]:
//! whole in the kernel, in parts in its `_in_parts` variant). The context compiles exactly these sources, and the tests below parse and validate them with naga
//! (no device needed), so a kernel that does not compile fails `cargo test` anywhere, not only
//! where a GPU is.

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
/// The pair histories' two halves; needs `ctrl` bound and `history_even` and `history_odd` split
/// ([`SPLIT`]).
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

/// Bindings a list of f64 may be split across. A device binds at most so many bytes at once
/// (2^31 - 1 on NVIDIA's Vulkan through wgpu, 128 MiB on lavapipe); the lists of a segment that
/// grow with its pair and wall slots, the pair histories (48 bytes a slot in each of three
/// lists), the wall outputs (80 bytes a wall slot) and the wall histories (48, in two), are the
/// largest, so they may be bound in parts ([`SPLIT`]) and the scenes that fit the resident path
/// grow this many times. Four keep the busiest kernel (`commit_in_parts`, 29 bindings) within the
/// 32 storage bindings lavapipe allows a kernel.
pub(crate) const PARTS: usize = 4;

/// A kernel's split lists: each list's name and whether the kernel writes it.
type Lists = &'static [(&'static str, bool)];

/// The lists each kernel may bind in [`PARTS`] parts: the kernel, the name of its variant that
/// binds them so (none: the stage path's `pair_forces`, whose lists fit one binding), and each
/// list's name and whether the kernel writes it. The kernel itself binds each list whole, in one
/// binding and with plain accessors; its variant in parts selects a part at every access, which
/// costs (on lavapipe the settle bench ran 1.5 times slower with every segment in parts), so a
/// segment uses the variants only where a list passes one binding. The host binds the lists in
/// this order after the kernel's own bindings.
const SPLIT: &[(&str, Option<&str>, Lists)] = &[
    ("pair_forces", None, &[("history", true), ("output", true)]),
    (
        "wall_forces",
        Some("wall_forces_in_parts"),
        &[("history", true), ("output", true)],
    ),
    (
        "build_pairs",
        Some("build_pairs_in_parts"),
        &[
            ("history_even", true),
            ("history_odd", true),
            ("new_pair_history", true),
        ],
    ),
    (
        "build_walls",
        Some("build_walls_in_parts"),
        &[("old_history", false), ("new_history", true)],
    ),
    (
        "commit",
        Some("commit_in_parts"),
        &[
            ("history_even", true),
            ("history_odd", true),
            ("new_pair_history", false),
            ("wall_history", true),
            ("new_wall_history", false),
        ],
    ),
    (
        "particle_forces",
        Some("particle_forces_in_parts"),
        &[
            ("history_even", true),
            ("history_odd", true),
            ("walls", false),
        ],
    ),
    (
        "geometry_loads",
        Some("geometry_loads_in_parts"),
        &[("output", false)],
    ),
];

/// Whether `kernel` is a variant that binds its lists in parts ([`SPLIT`]).
pub(crate) fn in_parts(kernel: &str) -> bool {
    SPLIT.iter().any(|(_, variant, _)| *variant == Some(kernel))
}

/// The numbers of a split list's part on a device that binds at most `max_binding` bytes: whole
/// histories, so that a history's six numbers lie in one part (a wall output's ten may lie in
/// two: the accessors take each number from its own part).
pub(crate) fn part_numbers(max_binding: u64) -> usize {
    let row = layout::history::LEN;
    let numbers = (max_binding / 8).min(u32::MAX as u64) as usize;
    (numbers / row * row).max(row)
}

/// The WGSL of `lists` bound in `parts` parts (1 or [`PARTS`]) from binding `first` on: each
/// part's binding, then `NAME_get(k)` (and `NAME_put(k, v)` where written) over the list as one,
/// number k being number `k % PART_NUMBERS` of part `k / PART_NUMBERS` (in one part, number k of
/// it). WGSL cannot pass a storage array to a function, so each list gets its own accessors.
fn split_lists(first: usize, lists: &[(&str, bool)], parts: usize) -> String {
    let mut out = String::new();
    let mut binding = first;
    for &(name, writes) in lists {
        let access = if writes { "read_write" } else { "read" };
        for p in 0..parts {
            out += &format!(
                "@group(0) @binding({binding}) var<storage, {access}> {name}_{p}: array<f64>;\n"
            );
            binding += 1;
        }
        if parts == 1 {
            out += &format!("fn {name}_get(k: u32) -> f64 {{\n    return {name}_0[k];\n}}\n");
            if writes {
                out += &format!("fn {name}_put(k: u32, v: f64) {{\n    {name}_0[k] = v;\n}}\n");
            }
            continue;
        }
        let cases = |body: &dyn Fn(usize) -> String| {
            (0..parts)
                .map(|p| match p + 1 == parts {
                    false => format!("        case {p}u: {{ {} }}\n", body(p)),
                    true => format!("        default: {{ {} }}\n", body(p)),
                })
                .collect::<String>()
        };
        out += &format!(
            "fn {name}_get(k: u32) -> f64 {{\n    let r = k % PART_NUMBERS;\n    switch (k / PART_NUMBERS) {{\n{}    }}\n}}\n",
            cases(&|p| format!("return {name}_{p}[r];"))
        );
        if writes {
            out += &format!(
                "fn {name}_put(k: u32, v: f64) {{\n    let r = k % PART_NUMBERS;\n    switch (k / PART_NUMBERS) {{\n{}    }}\n}}\n",
                cases(&|p| format!("{name}_{p}[r] = v;"))
            );
        }
    }
    out
}

/// Every kernel's name and full source, as a device that binds at most `max_binding` bytes
/// compiles it.
pub(crate) fn kernel_sources(max_binding: u64) -> Vec<(&'static str, String)> {
    let constants = format!(
        "{}const PART_NUMBERS: u32 = {}u;\n",
        layout::wgsl_constants(),
        part_numbers(max_binding)
    );
    let mut sources = Vec::new();
    for &(name, parts) in KERNELS {
        let source = [constants.as_str(), VECTOR]
            .into_iter()
            .chain(parts.iter().copied())
            .collect::<Vec<_>>()
            .join("\n");
        let Some(&(_, in_parts, lists)) = SPLIT.iter().find(|(kernel, ..)| *kernel == name) else {
            sources.push((name, source));
            continue;
        };
        // The lists come after the kernel's own bindings, numbered 0 on.
        let own = source.matches("@binding(").count();
        sources.push((name, format!("{source}{}", split_lists(own, lists, 1))));
        if let Some(in_parts) = in_parts {
            sources.push((
                in_parts,
                format!("{source}{}", split_lists(own, lists, PARTS)),
            ));
        }
    }
    sources
}

#[cfg(test)]
mod tests;
