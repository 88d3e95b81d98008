// The geometry poses of the step that `begin` started: the moving elements' rows and every
// geometry's row (its velocity field) of step s copied from the host's tracks into the rows the
// wall kernels read. One launch in the step's pass, where there were a copy per moving geometry
// and one of the geometry rows between the passes of two steps.
//
// table (u32): the element each moving row goes to, in the tracks' order.

@group(0) @binding(0) var<storage, read> ctrl: array<u32>;
@group(0) @binding(1) var<storage, read> dims: array<u32>;
@group(0) @binding(2) var<storage, read> counts: array<u32>;
@group(0) @binding(3) var<storage, read> table: array<u32>;
@group(0) @binding(4) var<storage, read> element_track: array<f64>;
@group(0) @binding(5) var<storage, read> geoms_track: array<f64>;
@group(0) @binding(6) var<storage, read_write> elements: array<f64>;
@group(0) @binding(7) var<storage, read_write> geoms: array<f64>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = gid.x + gid.y * counts[C_ROW_WIDTH];
    let s = ctrl[K_STEPS_BEGUN] - 1u;
    let moving = dims[D_MOVING_ELEMENTS];
    let geometries = dims[D_GEOMETRIES];
    if (t < moving) {
        let src = E_LEN * (s * moving + t);
        let to = E_LEN * table[t];
        for (var k = 0u; k < E_LEN; k++) {
            elements[to + k] = element_track[src + k];
        }
    } else if (t < moving + geometries) {
        let r = t - moving;
        let src = G_LEN * (s * geometries + r);
        let to = G_LEN * r;
        for (var k = 0u; k < G_LEN; k++) {
            geoms[to + k] = geoms_track[src + k];
        }
    }
}
