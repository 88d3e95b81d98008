// The params block of one world of a batch (crate::PARAMS numbers each; common.wgsl lists the
// whole block): the numbers the resident kernels read by name.

const PARAMS: u32 = 24u;
// 1 stepping, 2 its steps just ended (checked only), 0 done or failed.
const P_STEPPING: u32 = 17u;
const P_STEPS: u32 = 18u;
const P_FIRST_GEOMETRY: u32 = 19u;
const P_END_GEOMETRY: u32 = 20u;
const P_FIRST_PARTICLE: u32 = 21u;
const P_END_PARTICLE: u32 = 22u;
// Where the world's material pair table starts in `table`.
const P_TABLE: u32 = 23u;
