// Shared by the device-resident kernels (crate::resident): the list layout and the cell hash.
//
// props: as the stage kernels' (block 4: each particle's world).
// dims (u32): 0 particles N, 1 pair row capacity, 2 wall row capacity, 3 hash buckets M (a power
//   of two), 4 bucket capacity, 5 geometries, 6 elements
// search (f64): 0 inverse cell size, 1 pair reach beyond touching, 2 wall reach beyond touching,
//   3 (half the skin) squared
// ctrl (atomic u32): 0 steps begun, 1 rebuild in this step, 2 unused, 3 overflow (0 none, 1 a
//   bucket, 2 a pair row, 3 a reverse row, 4 a wall row, 5 more wall contacts than the wall
//   kernel keeps), 4 rebuilds, 5 worlds W, 8 + w world w's first failed step (0xffffffff: none)
// params: a block of PARAMS numbers per world (common.wgsl, world.wgsl); a world that does not
//   step is left out of rebuilds.
// Pair rows have a fixed capacity: particle i's pairs (i < j, sorted by j) sit in slots
// i * capacity.., empty slots hold EMPTY; wall rows likewise.

const EMPTY: u32 = 0xffffffffu;

// Cells of the search grid: floor(x / cell), clamped far outside any scene.
fn cell_coord(x: f64, inv_cell: f64) -> i32 {
    var c = x * inv_cell;
    if (c < -1.0e9lf) {
        c = -1.0e9lf;
    }
    if (c > 1.0e9lf) {
        c = 1.0e9lf;
    }
    var t = i32(c);
    if (f64(t) > c) {
        t -= 1;
    }
    return t;
}

fn cell_of(x: vec3<f64>, inv_cell: f64) -> vec3<i32> {
    return vec3<i32>(cell_coord(x.x, inv_cell), cell_coord(x.y, inv_cell), cell_coord(x.z, inv_cell));
}

// A cell's bucket: spatial hashing (Teschner et al. 2003), so the grid needs no bounds; the
// world of a batch is hashed in, so that worlds in the same place fill different buckets.
fn bucket_of(c: vec3<i32>, world: u32, buckets: u32) -> u32 {
    let h = (u32(c.x) * 73856093u) ^ (u32(c.y) * 19349663u) ^ (u32(c.z) * 83492791u)
        ^ (world * 2654435761u);
    return h & (buckets - 1u);
}
