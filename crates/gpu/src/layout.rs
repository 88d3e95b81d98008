//! The data contract between the host and the WGSL kernels: where every number of every buffer
//! they share sits, declared once.
//!
//! Each layout is a module of `usize` constants (the place of each field in an item, and `LEN`,
//! the numbers one item takes) that the host's writers and readers index with, and a table from
//! which [`wgsl_constants`] writes the same places as WGSL `const`s, with one prefix per layout
//! (`P_STEPPING`, `H_ROLLING`, `S_VELOCITY`, ...). Every kernel's source starts with them
//! (`crate::kernels`), so a field moved here moves on both sides, and a kernel that still reads a
//! place by number fails the crate's scan of the WGSL files (`kernels::tests`) rather than the
//! CPU/GPU agreement tests.
//!
//! Three kinds of buffer are laid out:
//! - *rows*: items of `LEN` numbers, item `k`'s field `F` at `LEN * k + F` (the params block of a
//!   world, the material pair table, element and geometry rows, contact histories, the outputs of
//!   the force kernels, pair and candidate indices, geometry loads);
//! - *blocks of N* (structure of arrays over the N particles): field `F` is a block that starts
//!   at `F * N`, holding one number per particle, or three for a vector field, particle `i`'s at
//!   `F * N + i` or `F * N + 3 * i` (`state`, `loads`, `props`, `ints`, `rows`);
//! - *words*: a small buffer of named words (`counts`, and the segment's `dims`, `search`,
//!   `ctrl`).
//!
//! Fields tile their item: each starts where the one before ends and the last ends at `LEN`
//! (tested below), except in the element row, where every element kind puts its own fields after
//! the kind code in the same places. A field of width [`OPEN`] is a tail that runs to the end of
//! the buffer (one number per world, the reverse entries); it comes last and `LEN` stops before
//! it. Besides the layouts, two lists of codes are shared: element kinds and overflow causes.

/// The width of a field that runs to the end of its buffer (see the module notes).
pub(crate) const OPEN: usize = 0;

/// How the fields of a layout share its item.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Tiling {
    /// Each field starts where the one before it ends; the last ends at `LEN`.
    Contiguous,
    /// After a common head (the fields not named after a kind), each kind's fields (named
    /// `KIND_FIELD`) tile the rest from the same place; they may stop short of `LEN`.
    PerKind,
}

/// One laid-out buffer, as the WGSL constants are written from it.
pub(crate) struct Layout {
    /// The module's name, for messages.
    pub name: &'static str,
    /// The prefix of its WGSL constants.
    pub prefix: &'static str,
    pub len: usize,
    pub tiling: Tiling,
    /// Name, place and width of every field, in the order declared.
    pub fields: &'static [(&'static str, usize, usize)],
}

/// A list of codes the host and the kernels agree on.
pub(crate) struct Codes {
    pub name: &'static str,
    pub prefix: &'static str,
    pub codes: &'static [(&'static str, u32)],
}

/// Declares a layout: `name, "PREFIX_", Tiling, len LEN { FIELD: place, width; ... }`.
macro_rules! layout {
    (
        $(#[$doc:meta])*
        $name:ident, $prefix:literal, $tiling:ident, len $len:literal {
            $( $(#[$field_doc:meta])* $field:ident: $place:literal, $width:expr; )*
        }
    ) => {
        $(#[$doc])*
        pub(crate) mod $name {
            $( $(#[$field_doc])* pub(crate) const $field: usize = $place; )*
            /// Numbers (or blocks of N, or words) one item takes.
            pub(crate) const LEN: usize = $len;
            pub(crate) const LAYOUT: super::Layout = super::Layout {
                name: stringify!($name),
                prefix: $prefix,
                len: LEN,
                tiling: super::Tiling::$tiling,
                fields: &[$((stringify!($field), $field, $width)),*],
            };
        }
    };
}

/// Declares a list of codes: `name, "PREFIX_" { CODE = value; ... }`.
macro_rules! codes {
    (
        $(#[$doc:meta])*
        $name:ident, $prefix:literal {
            $( $(#[$code_doc:meta])* $code:ident = $value:literal; )*
        }
    ) => {
        $(#[$doc])*
        pub(crate) mod $name {
            $( $(#[$code_doc])* pub(crate) const $code: u32 = $value; )*
            pub(crate) const CODES: super::Codes = super::Codes {
                name: stringify!($name),
                prefix: $prefix,
                codes: &[$((stringify!($code), $code)),*],
            };
        }
    };
}

layout! {
    /// `params`: one block per world of a batch (a simulation run stage by stage is world 0), so
    /// that worlds with other time steps, gravity or rolling models share launches. Material and
    /// geometry indices are the world's own; the host sets the last eight per segment.
    params, "P_", Contiguous, len 25 {
        /// The time step.
        DT: 0, 1;
        GRAVITY: 1, 3;
        /// 1 when the simulation has a domain box (a particle leaving it fails the run).
        HAS_DOMAIN: 4, 1;
        DOMAIN_LOW: 5, 3;
        DOMAIN_HIGH: 8, 3;
        /// 1 when the scene has clumps: the members of one body skip each other in the pair
        /// kernel and are moved by their body (on the device in a segment, on the host stage by
        /// stage), not by the kick and drift.
        CLUMPS: 11, 1;
        /// 1 when the particle sums give the second half kick.
        KICK: 12, 1;
        /// 0 cdt (constant directional torque), 1 epsd.
        ROLLING_MODEL: 13, 1;
        /// epsd's rolling viscous damping ratio.
        ROLLING_DAMPING: 14, 1;
        /// Materials of the world: the side of its pair table.
        MATERIALS: 15, 1;
        /// 1 when some material pair has a surface energy (JKR contacts reach past touching).
        COHESIVE: 16, 1;
        /// 1 stepping, 2 its steps just ended (its last kick is checked only), 0 done or failed.
        STEPPING: 17, 1;
        /// The world's own number of steps in the segment.
        STEPS: 18, 1;
        /// The world's geometries are FIRST_GEOMETRY..END_GEOMETRY of the batch's.
        FIRST_GEOMETRY: 19, 1;
        END_GEOMETRY: 20, 1;
        /// The world's particles are FIRST_PARTICLE..END_PARTICLE of the batch's.
        FIRST_PARTICLE: 21, 1;
        END_PARTICLE: 22, 1;
        /// Where the world's material pair table starts in `table`.
        TABLE: 23, 1;
        /// 1 when the world's bonds run with it in the segment: the bond sums add their forces
        /// after the particle sums and give the second half kick instead of them.
        BONDS: 24, 1;
    }
}

layout! {
    /// `table`: the contact parameters of material pair (a, b) at `P_TABLE + LEN * (a * materials
    /// + b)` (`dem::contact::PairParams`).
    table, "T_", Contiguous, len 7 {
        /// Effective Young's modulus.
        E_STAR: 0, 1;
        /// Effective shear modulus.
        G_STAR: 1, 1;
        /// The tangential damping coefficient over the normal one; 0: Hertz's damping factor
        /// with the tangential stiffness instead.
        TANGENTIAL_DAMPING_RATIO: 2, 1;
        /// Hertz-Mindlin's damping factor (from the restitution coefficient).
        HERTZ_DAMPING: 3, 1;
        STATIC_FRICTION: 4, 1;
        ROLLING_FRICTION: 5, 1;
        /// JKR surface energy (0: no cohesion).
        SURFACE_ENERGY: 6, 1;
    }
}

layout! {
    /// `elements`: one row per geometry element (`dem::geometry::Element`): its kind (an
    /// [`element_kind`](super::element_kind) code), then that kind's points, directions and
    /// sizes. The kinds' fields overlap: each kind uses the places after `KIND` for its own
    /// numbers (a rectangle the most, 15), and the rest of a row is zero.
    element, "E_", PerKind, len 16 {
        /// The element's kind ([`element_kind`](super::element_kind)).
        KIND: 0, 1;
        /// A plane: a point on it and its unit normal (one-sided: behind it is outside).
        PLANE_POINT: 1, 3;
        PLANE_NORMAL: 4, 3;
        /// A rectangle: its centre, normal, unit edge directions u and v and half extents.
        RECT_CENTER: 1, 3;
        RECT_NORMAL: 4, 3;
        RECT_U: 7, 3;
        RECT_V: 10, 3;
        RECT_HALF_U: 13, 1;
        RECT_HALF_V: 14, 1;
        /// A disc: its centre, normal and radius.
        DISC_CENTER: 1, 3;
        DISC_NORMAL: 4, 3;
        DISC_RADIUS: 7, 1;
        /// A cylinder shell: the centre of its base, its unit axis, radius and length.
        CYLINDER_BASE: 1, 3;
        CYLINDER_AXIS: 4, 3;
        CYLINDER_RADIUS: 7, 1;
        CYLINDER_LENGTH: 8, 1;
        /// A triangle: its corners.
        TRIANGLE_A: 1, 3;
        TRIANGLE_B: 4, 3;
        TRIANGLE_C: 7, 3;
    }
}

codes! {
    /// The kind code in an element row's `KIND` place.
    element_kind, "EK_" {
        PLANE = 0;
        RECT = 1;
        DISC = 2;
        CYLINDER = 3;
        TRIANGLE = 4;
    }
}

layout! {
    /// `geoms`: one row per geometry. The wall kernel evaluates the contact velocity from the
    /// velocity field (the pose is already in the element rows).
    geometry, "G_", Contiguous, len 8 {
        MATERIAL: 0, 1;
        /// Its first element in `elements` (its elements run to the next geometry's first).
        FIRST_ELEMENT: 1, 1;
        LINEAR_VELOCITY: 2, 3;
        /// Angular velocity about the origin.
        ANGULAR_VELOCITY: 5, 3;
    }
}

layout! {
    /// `history`: what a contact carries from step to step (`dem::contact::ContactHistory`), one
    /// row per pair or wall candidate slot; all zero for a contact not in touch.
    history, "H_", Contiguous, len 6 {
        /// The tangential spring.
        TANGENTIAL: 0, 3;
        /// The epsd rolling moment.
        ROLLING: 3, 3;
    }
}

layout! {
    /// `output` of the pair kernel, one row per pair slot (`dem::neighbour::PairOutput`), summed
    /// by the particle sums: i adds the force, j subtracts it.
    pair_output, "PO_", Contiguous, len 11 {
        /// Force on i (normal and tangential).
        FORCE: 0, 3;
        TORQUE_I: 3, 3;
        TORQUE_J: 6, 3;
        /// cdt's rolling torque limits of i and j.
        ROLLING_I: 9, 1;
        ROLLING_J: 10, 1;
    }
}

layout! {
    /// `output` of the wall kernel, one row per wall candidate slot
    /// (`dem::sim::walls::WallOutput`).
    wall_output, "WO_", Contiguous, len 10 {
        /// Force on the geometry (the particle gets its opposite).
        FORCE: 0, 3;
        /// Torque on the geometry about the origin.
        TORQUE: 3, 3;
        PARTICLE_TORQUE: 6, 3;
        /// cdt's rolling torque limit of the particle.
        ROLLING: 9, 1;
    }
}

layout! {
    /// `pair_ij` (u32): the two particles of a pair slot; `i` is `EMPTY` in an empty slot of a
    /// fixed-capacity row.
    pair_ij, "IJ_", Contiguous, len 2 {
        I: 0, 1;
        J: 1, 1;
    }
}

layout! {
    /// `cands` (u32): a wall candidate slot, a geometry and an element within it.
    cands, "WC_", Contiguous, len 2 {
        GEOMETRY: 0, 1;
        ELEMENT: 1, 1;
    }
}

layout! {
    /// The segment's geometry loads, one row per geometry (`dem::geometry::Load`).
    geometry_loads, "GL_", Contiguous, len 6 {
        FORCE: 0, 3;
        /// Torque about the origin.
        TORQUE: 3, 3;
    }
}

layout! {
    /// `bond_state`: one row per bond of a segment (`dem::bond::segment::STATE_LEN` numbers, in
    /// its order): what a bond carries from step to step.
    bond_state, "BS_", Contiguous, len 11 {
        /// Along the axis, positive pushing the spheres apart.
        NORMAL_FORCE: 0, 1;
        SHEAR_FORCE: 1, 3;
        /// The twisting moment about the axis.
        TWIST: 4, 1;
        BENDING: 5, 3;
        /// The axis (from the second sphere to the first) at the last update.
        AXIS: 8, 3;
    }
}

layout! {
    /// `bond_output`: one row per bond (`dem::bond::segment::OUTPUT_LEN` numbers), what it does
    /// to its spheres in the step (zero once broken).
    bond_output, "BO_", Contiguous, len 9 {
        /// Force on the first sphere (the second gets its opposite).
        FORCE: 0, 3;
        TORQUE_FIRST: 3, 3;
        TORQUE_SECOND: 6, 3;
    }
}

layout! {
    /// `bond_params`: one row per bond kind of a batch (`dem::bond::BondParams`; each world's
    /// kinds after those of the worlds before it).
    bond_params, "BP_", Contiguous, len 5 {
        /// k_n and k_t (N/m^3).
        NORMAL_STIFFNESS: 0, 1;
        SHEAR_STIFFNESS: 1, 1;
        /// sigma_c and tau_c (Pa).
        CRITICAL_NORMAL_STRESS: 2, 1;
        CRITICAL_SHEAR_STRESS: 3, 1;
        /// The local damping fraction of the bonded spheres.
        DAMPING: 4, 1;
    }
}

layout! {
    /// `bond_ends` (u32): one row per bond, its spheres (the batch's indices), its kind (a row
    /// of `bond_params`) and whether it is intact (the bond kernel clears it when it breaks).
    bond_ends, "BE_", Contiguous, len 4 {
        FIRST: 0, 1;
        SECOND: 1, 1;
        KIND: 2, 1;
        INTACT: 3, 1;
    }
}

layout! {
    /// `bond_props`: one row per bond, what does not change in a segment.
    bond_props, "BQ_", Contiguous, len 2 {
        /// R_B (m).
        RADIUS: 0, 1;
        /// The bond's own factor on k_n and k_t.
        STIFFNESS: 1, 1;
    }
}

layout! {
    /// `bond_broke`: one row per bond, the step (within the segment) in which it broke, -1 while
    /// intact, and its mid-point then.
    bond_broke, "BB_", Contiguous, len 4 {
        STEP: 0, 1;
        POSITION: 1, 3;
    }
}

layout! {
    /// `bond_rows` (u32), in blocks of N: each particle's bonds as a range begin..end of the
    /// slots that follow, each slot `2 b` where it is bond b's first sphere and `2 b + 1` where
    /// it is its second, in bond order.
    bond_rows, "BN_", Contiguous, len 2 {
        BEGIN: 0, 1;
        END: 1, 1;
        /// The slots of every particle's row, one after another.
        SLOTS: 2, super::OPEN;
    }
}

layout! {
    /// `bodies`: one row per clump body of a segment (`dem::sim::SegmentBodies`).
    body, "BD_", Contiguous, len 24 {
        /// The centre of mass.
        POSITION: 0, 3;
        VELOCITY: 3, 3;
        /// Body to space: the quaternion's vector part x, y, z and its scalar w.
        ORIENTATION: 6, 3;
        ORIENTATION_W: 9, 1;
        /// In the space frame.
        ANGULAR_MOMENTUM: 10, 3;
        /// The principal moments of inertia.
        INERTIA: 13, 3;
        MASS: 16, 1;
        /// The force and torque (about the centre of mass) of the last step, and the summed
        /// constant-directional rolling limit of the members.
        FORCE: 17, 3;
        TORQUE: 20, 3;
        ROLLING_LIMIT: 23, 1;
    }
}

layout! {
    /// `body_members` (u32): one row per body, its members as a range begin..end of `members`
    /// (particle indices, with their rows of `offsets` at the same places).
    body_members, "BM_", Contiguous, len 2 {
        BEGIN: 0, 1;
        END: 1, 1;
    }
}

layout! {
    /// `offsets`: one row per clump member, its offset from its body's centre of mass in the
    /// body frame.
    member, "MB_", Contiguous, len 3 {
        OFFSET: 0, 3;
    }
}

layout! {
    /// `state`, in blocks of N: what the kick and drift advance (three numbers a particle each).
    state, "S_", Contiguous, len 9 {
        POSITION: 0, 3;
        VELOCITY: 3, 3;
        ANGULAR_VELOCITY: 6, 3;
    }
}

layout! {
    /// `loads`, in blocks of N: what the particle sums write and the kicks read.
    loads, "L_", Contiguous, len 7 {
        FORCE: 0, 3;
        TORQUE: 3, 3;
        /// cdt's rolling torque limit (one number a particle).
        ROLLING_LIMIT: 6, 1;
    }
}

layout! {
    /// `props`, in blocks of N, one number a particle each.
    props, "PR_", Contiguous, len 5 {
        RADIUS: 0, 1;
        MASS: 1, 1;
        INV_MASS: 2, 1;
        INV_INERTIA: 3, 1;
        /// Its world in a batch (0 run stage by stage), which picks its params block.
        WORLD: 4, 1;
    }
}

layout! {
    /// `ints` (u32), in blocks of N.
    ints, "I_", Contiguous, len 2 {
        /// Its material, the world's own index.
        MATERIAL: 0, 1;
        /// Its clump body, or `NO_BODY` for a free sphere.
        BODY: 1, 1;
    }
}

layout! {
    /// `rows` (u32), in blocks of N: each particle's pair, reverse and wall rows as slot ranges
    /// begin..end, then the reverse entries (the pair slots in which a particle is j, found
    /// through its reverse row). Rows may have gaps between them: a segment keeps a fixed
    /// capacity per particle.
    rows, "R_", Contiguous, len 6 {
        PAIR_BEGIN: 0, 1;
        PAIR_END: 1, 1;
        REVERSE_BEGIN: 2, 1;
        REVERSE_END: 3, 1;
        WALL_BEGIN: 4, 1;
        WALL_END: 5, 1;
        /// The reverse entries, as many as the lists hold.
        REVERSE_ENTRIES: 6, super::OPEN;
    }
}

layout! {
    /// `counts` (u32): the sizes a stage kernel works over. A segment sets every count; a stage
    /// run alone only those its kernel reads.
    counts, "C_", Contiguous, len 7 {
        PARTICLES: 0, 1;
        PAIRS: 1, 1;
        REVERSE: 2, 1;
        /// Wall candidates.
        WALLS: 3, 1;
        /// Threads in a row of a 2-D dispatch (a thread's index is x + y * ROW_WIDTH).
        ROW_WIDTH: 4, 1;
        /// Bonds of a segment.
        BONDS: 5, 1;
        /// Clump bodies of a segment.
        BODIES: 6, 1;
    }
}

layout! {
    /// `dims` (u32): the sizes of a segment's fixed-capacity lists.
    dims, "D_", Contiguous, len 8 {
        PARTICLES: 0, 1;
        /// Slots of a particle's pair row, and of its reverse row.
        PAIR_CAPACITY: 1, 1;
        WALL_CAPACITY: 2, 1;
        /// Buckets of the cell hash (a power of two).
        BUCKETS: 3, 1;
        BUCKET_CAPACITY: 4, 1;
        GEOMETRIES: 5, 1;
        ELEMENTS: 6, 1;
        /// Elements of moving geometries (the rows of each step in the element track).
        MOVING_ELEMENTS: 7, 1;
    }
}

layout! {
    /// `search` (f64): the reaches of a segment's list rebuilds.
    search, "SE_", Contiguous, len 4 {
        /// One over the cell size of the hash grid.
        INV_CELL: 0, 1;
        /// How far beyond touching a pair is listed (the skin, and a cohesive cut-off).
        PAIR_REACH: 1, 1;
        WALL_REACH: 2, 1;
        /// (Half the skin) squared: a particle moved that far since the last rebuild asks for one.
        HALF_SKIN_SQUARED: 3, 1;
    }
}

layout! {
    /// `ctrl` (atomic u32): a segment's control words, written by the kernels and read by the
    /// host every `CHUNK` steps, so a run needs no host round trip to decide anything.
    ctrl, "K_", Contiguous, len 5 {
        /// Steps begun (the step `begin` starts is this before it adds one).
        STEPS_BEGUN: 0, 1;
        /// Nonzero when the lists are rebuilt in this step (forced by geometry motion or a
        /// particle's displacement).
        REBUILD: 1, 1;
        /// Why the run must be tried again or declined (an [`overflow`](super::overflow) code).
        OVERFLOW: 2, 1;
        /// Rebuilds run (the first, before the first step, included).
        REBUILDS: 3, 1;
        /// Worlds in the batch.
        WORLDS: 4, 1;
        /// One word per world: the first step in which it failed (not finite or out of its
        /// domain), `EMPTY` while none did.
        FAILED: 5, super::OPEN;
    }
}

codes! {
    /// What overflowed in a segment (`K_OVERFLOW`, the largest code raised wins): a capacity to
    /// double before the run is tried again, or a particle the wall kernel cannot take.
    overflow, "OV_" {
        NONE = 0;
        /// A cell bucket.
        BUCKET = 1;
        PAIR_ROW = 2;
        REVERSE_ROW = 3;
        WALL_ROW = 4;
        /// A particle touched more walls at once than the wall kernel keeps (declined).
        WALLS_KEPT = 5;
    }
}

/// Every layout, in the order their constants are written.
pub(crate) const LAYOUTS: &[Layout] = &[
    params::LAYOUT,
    table::LAYOUT,
    element::LAYOUT,
    geometry::LAYOUT,
    history::LAYOUT,
    pair_output::LAYOUT,
    wall_output::LAYOUT,
    pair_ij::LAYOUT,
    cands::LAYOUT,
    geometry_loads::LAYOUT,
    bond_state::LAYOUT,
    bond_output::LAYOUT,
    bond_params::LAYOUT,
    bond_ends::LAYOUT,
    bond_props::LAYOUT,
    bond_broke::LAYOUT,
    body::LAYOUT,
    body_members::LAYOUT,
    member::LAYOUT,
    state::LAYOUT,
    loads::LAYOUT,
    props::LAYOUT,
    ints::LAYOUT,
    rows::LAYOUT,
    bond_rows::LAYOUT,
    counts::LAYOUT,
    dims::LAYOUT,
    search::LAYOUT,
    ctrl::LAYOUT,
];

/// Every list of codes.
pub(crate) const CODES: &[Codes] = &[element_kind::CODES, overflow::CODES];

/// The WGSL constants of every layout and code list (`const P_DT: u32 = 0u;`, and `P_LEN` for
/// a layout's item), put in front of every kernel.
pub(crate) fn wgsl_constants() -> String {
    let mut text = String::from(
        "// Generated from crates/gpu/src/layout.rs, which says what every place holds.\n",
    );
    let line_comment = |text: &mut String, what: &str| text.push_str(&format!("// {what}\n"));
    let line = |text: &mut String, prefix: &str, name: &str, value: usize| {
        text.push_str(&format!("const {prefix}{name}: u32 = {value}u;\n"));
    };
    for l in LAYOUTS {
        let overlap = match l.tiling {
            Tiling::Contiguous => "",
            Tiling::PerKind => ", each kind's fields in the same places",
        };
        line_comment(&mut text, &format!("{} ({}){overlap}", l.name, l.prefix));
        for &(name, place, _) in l.fields {
            line(&mut text, l.prefix, name, place);
        }
        line(&mut text, l.prefix, "LEN", l.len);
    }
    for c in CODES {
        line_comment(&mut text, &format!("{} codes ({})", c.name, c.prefix));
        for &(name, value) in c.codes {
            line(&mut text, c.prefix, name, value as usize);
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// Checks that `fields` tile `from..len` in order: each starts where the one before ended.
    /// `strict`: the last must end at `len` (else anywhere up to it).
    fn tiles(what: &str, fields: &[(&str, usize, usize)], from: usize, len: usize, strict: bool) {
        let mut at = from;
        for (k, &(name, place, width)) in fields.iter().enumerate() {
            assert_eq!(place, at, "{what}: {name} starts at {place}, not at {at}");
            if width == OPEN {
                assert_eq!(
                    k + 1,
                    fields.len(),
                    "{what}: the open tail {name} is not last"
                );
                assert_eq!(
                    place, len,
                    "{what}: the open tail {name} does not start at LEN"
                );
            }
            at = place + width;
        }
        if strict {
            assert_eq!(at, len, "{what}: the fields end at {at}, LEN is {len}");
        } else {
            assert!(at <= len, "{what}: the fields end at {at}, past LEN {len}");
        }
    }

    #[test]
    fn fields_tile_their_items() {
        for l in LAYOUTS {
            match l.tiling {
                Tiling::Contiguous => tiles(l.name, l.fields, 0, l.len, true),
                Tiling::PerKind => {
                    let kinds = &element_kind::CODES;
                    let kind_of = |name: &str| {
                        kinds
                            .codes
                            .iter()
                            .find(|(k, _)| name.strip_prefix(k).is_some_and(|r| r.starts_with('_')))
                            .map(|(k, _)| *k)
                    };
                    let head: Vec<_> = l
                        .fields
                        .iter()
                        .copied()
                        .filter(|f| kind_of(f.0).is_none())
                        .collect();
                    tiles(l.name, &head, 0, l.len, false);
                    let after_head = head.last().map_or(0, |f| f.1 + f.2);
                    for &(kind, _) in kinds.codes {
                        let own: Vec<_> = l
                            .fields
                            .iter()
                            .copied()
                            .filter(|f| kind_of(f.0) == Some(kind))
                            .collect();
                        assert!(!own.is_empty(), "{}: the kind {kind} has no fields", l.name);
                        tiles(
                            &format!("{} {kind}", l.name),
                            &own,
                            after_head,
                            l.len,
                            false,
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn names_and_codes_are_unique() {
        let mut seen = BTreeMap::new();
        for l in LAYOUTS {
            for name in l.fields.iter().map(|f| f.0).chain(["LEN"]) {
                let full = format!("{}{name}", l.prefix);
                assert!(seen.insert(full.clone(), l.name).is_none(), "{full} twice");
            }
        }
        for c in CODES {
            let mut values: Vec<u32> = c.codes.iter().map(|c| c.1).collect();
            values.sort_unstable();
            values.dedup();
            assert_eq!(values.len(), c.codes.len(), "{}: a code twice", c.name);
            for (name, _) in c.codes {
                let full = format!("{}{name}", c.prefix);
                assert!(seen.insert(full.clone(), c.name).is_none(), "{full} twice");
            }
        }
    }

    /// The generated WGSL, read back, says what the Rust constants say.
    #[test]
    fn generated_constants_are_the_rust_ones() {
        let text = wgsl_constants();
        let mut parsed = BTreeMap::new();
        for line in text.lines().filter(|l| !l.starts_with("//")) {
            let rest = line.strip_prefix("const ").expect(line);
            let (name, value) = rest.split_once(": u32 = ").expect(line);
            let value: u32 = value.strip_suffix("u;").expect(line).parse().expect(line);
            assert!(
                parsed.insert(name.to_string(), value).is_none(),
                "{name} twice"
            );
        }
        let mut expected = BTreeMap::new();
        for l in LAYOUTS {
            for &(name, place, _) in l.fields {
                expected.insert(format!("{}{name}", l.prefix), place as u32);
            }
            expected.insert(format!("{}LEN", l.prefix), l.len as u32);
        }
        for c in CODES {
            for &(name, value) in c.codes {
                expected.insert(format!("{}{name}", c.prefix), value);
            }
        }
        assert_eq!(parsed, expected);
        // The tables hold the constants the host indexes with.
        for (name, value) in [
            ("P_STEPPING", params::STEPPING),
            ("P_LEN", params::LEN),
            ("T_SURFACE_ENERGY", table::SURFACE_ENERGY),
            ("E_RECT_HALF_V", element::RECT_HALF_V),
            ("PO_TORQUE_I", pair_output::TORQUE_I),
            ("S_ANGULAR_VELOCITY", state::ANGULAR_VELOCITY),
            ("R_REVERSE_ENTRIES", rows::REVERSE_ENTRIES),
            ("K_FAILED", ctrl::FAILED),
        ] {
            assert_eq!(parsed[name], value as u32, "{name}");
        }
        assert_eq!(parsed["EK_TRIANGLE"], element_kind::TRIANGLE);
        assert_eq!(parsed["OV_WALLS_KEPT"], overflow::WALLS_KEPT);
    }

    /// A bond's state and output rows are the engine's (`dem::bond::segment`), copied as they are.
    #[test]
    fn bond_rows_are_the_engines() {
        assert_eq!(bond_state::LEN, dem::bond::segment::STATE_LEN);
        assert_eq!(bond_output::LEN, dem::bond::segment::OUTPUT_LEN);
    }
}
