// Shared by the device-resident kernels that build lists (crate::resident): the list sentinel
// and the cell hash. Their words are the generated dims (D_), search (SE_) and ctrl (K_, with the
// OV_ overflow codes) of layout.rs; a world that does not step is left out of rebuilds.
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

// Teschner et al.'s primes for the cell coordinates, and Knuth's multiplicative constant for the
// world.
const HASH_X: u32 = 73856093u;
const HASH_Y: u32 = 19349663u;
const HASH_Z: u32 = 83492791u;
const HASH_WORLD: u32 = 2654435761u;

// A cell's bucket: spatial hashing (Teschner et al. 2003), so the grid needs no bounds; the
// world of a batch is hashed in, so that worlds in the same place fill different buckets.
fn bucket_of(c: vec3<i32>, world: u32, buckets: u32) -> u32 {
    let h = (u32(c.x) * HASH_X) ^ (u32(c.y) * HASH_Y) ^ (u32(c.z) * HASH_Z)
        ^ (world * HASH_WORLD);
    return h & (buckets - 1u);
}
