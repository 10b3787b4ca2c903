// A volumetric NURBS (sculpt_core::volume, Park 2005) evaluated at the points of a
// uniform parameter grid, one invocation per point (vr_app::gpu_volume).
//
// Per direction d: the grid parameter u_d (uploaded, rounded from f64 on the CPU),
// its knot span (P&T A2.1, binary search) and the p_d + 1 non-zero basis functions
// (P&T A2.2); then the homogeneous sum over the (p_1 + 1) .. (p_n + 1) local control
// points (P&T A4.3 extended to n directions) and the division by the weight (eq. 4.8).

const MAX_ORDER: u32 = 10u;   // sculpt_core::nurbs::MAX_DEGREE + 1
const MAX_DIM: u32 = 33u;     // sculpt_core::volume::MAX_COMPONENTS + 1
const MAX_DIRS: u32 = 4u;     // sculpt_core::volume::MAX_DIRECTIONS

struct Params {
    n: u32,        // directions
    k: u32,        // attributes
    count: u32,    // grid points in this chunk
    first: u32,    // the chunk's first grid point
    row: u32,      // invocations per row of a two-dimensional dispatch
    pad0: u32,
    pad1: u32,
    pad2: u32,
    res: vec4<u32>,      // grid points per direction
    degree: vec4<u32>,   // degree per direction
    ncp: vec4<u32>,      // control points per direction
    knot_at: vec4<u32>,  // where direction d's knots start in `coords`
    param_at: vec4<u32>, // where direction d's grid parameters start in `coords`
    stride: vec4<u32>,   // the net's stride (in points) of direction d
}

@group(0) @binding(0) var<uniform> P: Params;
// Every direction's knots, then every direction's grid parameters.
@group(0) @binding(1) var<storage, read> coords: array<f32>;
// The homogeneous net (h a_1 .. h a_k, h), k + 1 values per point, row-major.
@group(0) @binding(2) var<storage, read> net: array<f32>;
// k values per grid point of the chunk.
@group(0) @binding(3) var<storage, read_write> out: array<f32>;

// P&T A2.1: the span s with u_s <= u < u_{s+1}, the last non-empty one at the end.
fn find_span(d: u32, u: f32) -> u32 {
    let at = P.knot_at[d];
    let p = P.degree[d];
    let n = P.ncp[d] - 1u;
    if (u >= coords[at + n + 1u]) {
        return n;
    }
    if (u <= coords[at + p]) {
        return p;
    }
    var lo = p;
    var hi = n + 1u;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (u < coords[at + mid]) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    return lo;
}

// P&T A2.2: N_{s-p,p}(u) .. N_{s,p}(u).
fn basis(d: u32, s: u32, u: f32) -> array<f32, MAX_ORDER> {
    let at = P.knot_at[d];
    let p = P.degree[d];
    var nb: array<f32, MAX_ORDER>;
    var left: array<f32, MAX_ORDER>;
    var right: array<f32, MAX_ORDER>;
    nb[0] = 1.0;
    for (var j = 1u; j <= p; j++) {
        left[j] = u - coords[at + s + 1u - j];
        right[j] = coords[at + s + j] - u;
        var saved = 0.0;
        for (var r = 0u; r < j; r++) {
            let temp = nb[r] / (right[r + 1u] + left[j - r]);
            nb[r] = saved + right[r + 1u] * temp;
            saved = left[j - r] * temp;
        }
        nb[j] = saved;
    }
    return nb;
}

@compute @workgroup_size(64)
fn grid_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let local = gid.x + gid.y * P.row;
    if (local >= P.count) {
        return;
    }
    // The grid point's multi-index, the first direction fastest.
    var rest = P.first + local;
    var nb: array<array<f32, MAX_ORDER>, MAX_DIRS>;
    var start = 0u;
    for (var d = 0u; d < P.n; d++) {
        let i = rest % P.res[d];
        rest = rest / P.res[d];
        let u = coords[P.param_at[d] + i];
        let s = find_span(d, u);
        nb[d] = basis(d, s, u);
        start += (s - P.degree[d]) * P.stride[d];
    }
    let dim = P.k + 1u;
    var acc: array<f32, MAX_DIM>;
    for (var c = 0u; c < dim; c++) {
        acc[c] = 0.0;
    }
    // The local control points, an odometer with the last direction fastest.
    var off = vec4<u32>(0u);
    loop {
        var flat = start;
        var coef = 1.0;
        for (var d = 0u; d < P.n; d++) {
            flat += off[d] * P.stride[d];
            coef *= nb[d][off[d]];
        }
        let base = flat * dim;
        for (var c = 0u; c < dim; c++) {
            acc[c] += coef * net[base + c];
        }
        var d = P.n;
        var more = false;
        while (d > 0u) {
            d -= 1u;
            off[d] += 1u;
            if (off[d] <= P.degree[d]) {
                more = true;
                break;
            }
            off[d] = 0u;
        }
        if (!more) {
            break;
        }
    }
    let inv_w = 1.0 / acc[P.k];
    for (var c = 0u; c < P.k; c++) {
        out[local * P.k + c] = acc[c] * inv_w;
    }
}
