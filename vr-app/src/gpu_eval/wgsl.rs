//! WGSL generation: a tape as straight-line shader code, one `let` per instruction.
//!
//! Why generated code and not an interpreter over a storage buffer of ops: an
//! interpreter loads each op, branches on its opcode and keeps every slot in a
//! per-invocation array (local memory on every GPU), so each tape instruction costs a
//! dependent load, a divergent-free but wide `switch` and a scratch store. Straight-line
//! code lets the shader compiler keep values in registers, reuse them as they die,
//! inline the constants and schedule across instructions, as Fidget's JIT does on the
//! CPU; its cost is a compile per model, which is paid once per run (the JSON output
//! reports it separately). Tapes longer than [`MAX_GPU_TAPE`] are not compiled (the
//! caller falls back to the CPU path): driver compile time grows with the function.
//!
//! The semantics follow [`Unary::apply`] and [`Binary::apply`] in f32 (Fidget's op
//! set, docs/implicit.md): `min`, `max`, `compare` and `not` return NaN for NaN
//! arguments (WGSL's `min` and `max` leave it unspecified, so the generated code tests
//! explicitly), `round` rounds half away from zero (WGSL's rounds half to even), `mod`
//! is the least non-negative remainder, `atan2(a, b)` is the angle of the point `(b, a)`
//! (IEEE 754's signed zeros and pi at the origin).
//! Constants are written as their f32 bit patterns (`bitcast<f32>(0x...u)`), so they are
//! exact; infinite and NaN constants come from the uniform parameters at run time, since
//! WGSL refuses non-finite constant expressions.

use std::fmt::Write;

use sculpt_core::implicit::expr::Var;
use sculpt_core::implicit::tape::{Instr, Tape};
use sculpt_core::implicit::{Binary, Unary};

/// The most tape instructions compiled into one shader; longer tapes run on the CPU.
///
/// Fidget's largest shipped model (`prospero.vm`) has about 8,000 clauses; this leaves
/// room for twice that. WebGPU adapters report no limit on shader size, so the limit is
/// ours: a bound on the source handed to the driver (about 40 bytes a clause, under
/// 1 MiB) and on its compile time.
pub const MAX_GPU_TAPE: usize = 1 << 14;

/// Invocations per workgroup (one cell or point each).
pub const WORKGROUP_SIZE: u32 = 64;

/// The uniform parameters, as laid out in the shader's `Params` struct.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Params {
    /// Grid cells per axis (grid entry point); unused for points.
    pub n: [u32; 3],
    /// The index of the chunk's first cell or point.
    pub first: u32,
    /// Cells or points in this chunk.
    pub count: u32,
    /// Where the y and z centres start in the coordinate buffer (grid entry point).
    pub y_at: u32,
    /// Where the z centres start.
    pub z_at: u32,
    /// Invocations per row of the dispatch (workgroups along x times the workgroup
    /// size), for dispatches that are two-dimensional.
    pub row: u32,
    /// The bits of +infinity (so that the shader builds it at run time).
    pub inf_bits: u32,
    /// The bits of a quiet NaN.
    pub nan_bits: u32,
    /// Tile edge in x and y, in cells (tile entry point); 0 otherwise.
    pub tile: u32,
    /// Tile edge in z, in cells (tile entry point); 0 otherwise.
    pub tile_z: u32,
}

/// The WGSL text of `tape`, with three entry points:
///
/// - `grid_main`: cell `first + i` of an `n[0] x n[1] x n[2]` grid (x fastest), whose
///   coordinates are `coords[i]`, `coords[y_at + j]`, `coords[z_at + k]` (the cell
///   centres, computed on the CPU so both paths see the same f32 inputs);
/// - `points_main`: point `i` of the chunk at `coords[3 i .. 3 i + 3]`;
/// - `tiles_main`: invocation `g = first + i` is cell `g % c` of tile `t = g / c`
///   (`c = tile^2 tile_z` cells per tile, x fastest within the tile), whose first
///   cell's indices are the `u32` bits at `coords[z_at + n[2] + 3 t ..]`, after the
///   cell centres; a cell past the grid's end (in a tile cut by the grid's faces)
///   writes NaN, which the caller drops.
///
/// All write `out[i]` for `i < count`.
pub fn shader(tape: &Tape) -> String {
    let mut s = String::with_capacity(256 + 48 * tape.len());
    s.push_str(PRELUDE);
    s.push_str("fn tape(x: f32, y: f32, z: f32) -> f32 {\n");
    for (i, ins) in tape.instrs().iter().enumerate() {
        let _ = writeln!(s, "    let v{i}: f32 = {};", expression(*ins));
    }
    let _ = writeln!(s, "    return v{};\n}}", tape.len() - 1);
    s.push_str(ENTRY_POINTS);
    s
}

/// The right-hand side of one instruction.
fn expression(ins: Instr) -> String {
    match ins {
        Instr::Var(Var::X) => "x".into(),
        Instr::Var(Var::Y) => "y".into(),
        Instr::Var(Var::Z) => "z".into(),
        Instr::Const(c) => constant(c),
        Instr::Unary(op, a) => unary(op, &format!("v{a}")),
        Instr::Binary(op, a, b) => binary(op, &format!("v{a}"), &format!("v{b}")),
    }
}

/// An exact f32 constant.
fn constant(c: f32) -> String {
    if c.is_nan() {
        "nan_value()".into()
    } else if c == f32::INFINITY {
        "inf_value()".into()
    } else if c == f32::NEG_INFINITY {
        "-inf_value()".into()
    } else {
        format!("bitcast<f32>({:#010x}u)", c.to_bits())
    }
}

/// The WGSL of a one-argument op on the slot `a`.
fn unary(op: Unary, a: &str) -> String {
    match op {
        Unary::Neg => format!("-{a}"),
        Unary::Abs => format!("abs({a})"),
        Unary::Recip => format!("1.0 / {a}"),
        Unary::Sqrt => format!("sqrt({a})"),
        Unary::Square => format!("{a} * {a}"),
        Unary::Floor => format!("floor({a})"),
        Unary::Ceil => format!("ceil({a})"),
        Unary::Round => format!("op_round({a})"),
        Unary::Sin => format!("sin({a})"),
        Unary::Cos => format!("cos({a})"),
        Unary::Tan => format!("tan({a})"),
        Unary::Asin => format!("op_asin({a})"),
        Unary::Acos => format!("op_acos({a})"),
        Unary::Atan => format!("atan({a})"),
        Unary::Exp => format!("exp({a})"),
        Unary::Ln => format!("log({a})"),
        Unary::Not => format!("op_not({a})"),
    }
}

/// The WGSL of a two-argument op on the slots `a` and `b`.
fn binary(op: Binary, a: &str, b: &str) -> String {
    match op {
        Binary::Add => format!("{a} + {b}"),
        Binary::Sub => format!("{a} - {b}"),
        Binary::Mul => format!("{a} * {b}"),
        Binary::Div => format!("{a} / {b}"),
        Binary::Min => format!("op_min({a}, {b})"),
        Binary::Max => format!("op_max({a}, {b})"),
        Binary::Atan2 => format!("op_atan2({a}, {b})"),
        Binary::Compare => format!("op_compare({a}, {b})"),
        Binary::Mod => format!("op_mod({a}, {b})"),
        Binary::And => format!("select({b}, {a}, {a} == 0.0)"),
        Binary::Or => format!("select({b}, {a}, {a} != 0.0)"),
    }
}

/// Bindings and the ops that need more than one WGSL expression.
const PRELUDE: &str = r#"// Generated by vr-app gpu_eval from an implicit tape (docs/implicit.md).
struct Params {
    n: vec3<u32>,
    first: u32,
    count: u32,
    y_at: u32,
    z_at: u32,
    row: u32,
    inf_bits: u32,
    nan_bits: u32,
    tile: u32,
    tile_z: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> coords: array<f32>;
@group(0) @binding(2) var<storage, read_write> out: array<f32>;

fn inf_value() -> f32 { return bitcast<f32>(params.inf_bits); }
fn nan_value() -> f32 { return bitcast<f32>(params.nan_bits); }
fn is_nan(a: f32) -> bool { return !(a == a); }

fn op_min(a: f32, b: f32) -> f32 {
    return select(min(a, b), nan_value(), is_nan(a) || is_nan(b));
}
fn op_max(a: f32, b: f32) -> f32 {
    return select(max(a, b), nan_value(), is_nan(a) || is_nan(b));
}
fn op_compare(a: f32, b: f32) -> f32 {
    let c = select(select(0.0, 1.0, a > b), -1.0, a < b);
    return select(c, nan_value(), is_nan(a) || is_nan(b));
}
fn op_not(a: f32) -> f32 {
    return select(select(0.0, 1.0, a == 0.0), a, is_nan(a));
}
// Half away from zero, as Rust's f32::round: a - trunc(a) is exact.
fn op_round(a: f32) -> f32 {
    let t = trunc(a);
    return select(t, t + sign(a), abs(a - t) >= 0.5);
}
// asin and acos through atan2, with 1 - a^2 as (1 - a)(1 + a) (exact to a rounding):
// as accurate as atan2, where lavapipe's own asin and acos are off by 3e-4. NaN outside
// [-1, 1], as on the CPU.
fn op_asin(a: f32) -> f32 {
    return select(atan2(a, sqrt((1.0 - a) * (1.0 + a))), nan_value(), !(abs(a) <= 1.0));
}
fn op_acos(a: f32) -> f32 {
    return select(atan2(sqrt((1.0 - a) * (1.0 + a)), a), nan_value(), !(abs(a) <= 1.0));
}
// IEEE 754 (and Rust) at the origin: atan2(+-0, +0) = +-0, atan2(+-0, -0) = +-pi; WGSL
// leaves (0, 0) open.
fn op_atan2(a: f32, b: f32) -> f32 {
    if (a == 0.0 && b == 0.0) {
        let pi = select(0.0, bitcast<f32>(0x40490fdbu), (bitcast<u32>(b) >> 31u) == 1u);
        return select(pi, -pi, (bitcast<u32>(a) >> 31u) == 1u);
    }
    return atan2(a, b);
}
// The least non-negative remainder (Rust's f32::rem_euclid); WGSL's % truncates.
fn op_mod(a: f32, b: f32) -> f32 {
    let r = a - b * trunc(a / b);
    return select(r, r + abs(b), r < 0.0);
}

"#;

/// The entry points.
const ENTRY_POINTS: &str = r#"
fn invocation(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * params.row;
}

@compute @workgroup_size(64)
fn grid_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = invocation(gid);
    if (i >= params.count) {
        return;
    }
    let cell = params.first + i;
    let nx = params.n.x;
    let ny = params.n.y;
    let ix = cell % nx;
    let iy = (cell / nx) % ny;
    let iz = cell / (nx * ny);
    out[i] = tape(coords[ix], coords[params.y_at + iy], coords[params.z_at + iz]);
}

@compute @workgroup_size(64)
fn tiles_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = invocation(gid);
    if (i >= params.count) {
        return;
    }
    let g = params.first + i;
    let per_tile = params.tile * params.tile * params.tile_z;
    let t = g / per_tile;
    let l = g % per_tile;
    let at = params.z_at + params.n.z + 3u * t;
    let ix = bitcast<u32>(coords[at]) + l % params.tile;
    let iy = bitcast<u32>(coords[at + 1u]) + (l / params.tile) % params.tile;
    let iz = bitcast<u32>(coords[at + 2u]) + l / (params.tile * params.tile);
    if (ix >= params.n.x || iy >= params.n.y || iz >= params.n.z) {
        out[i] = nan_value();
        return;
    }
    out[i] = tape(coords[ix], coords[params.y_at + iy], coords[params.z_at + iz]);
}

@compute @workgroup_size(64)
fn points_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = invocation(gid);
    if (i >= params.count) {
        return;
    }
    out[i] = tape(coords[3u * i], coords[3u * i + 1u], coords[3u * i + 2u]);
}
"#;

#[cfg(test)]
mod tests {
    use super::*;
    use sculpt_core::implicit::Model;

    fn tape_of(vm: &str) -> Tape {
        Model::from_vm(vm).unwrap().tape_negative_inside()
    }

    #[test]
    fn every_instruction_is_one_let_and_the_last_is_returned() {
        let tape = tape_of("x var-x\ny var-y\ns add x y\nc const 2.5\nm mul s c\n");
        let wgsl = shader(&tape);
        let lets = wgsl
            .lines()
            .filter(|l| l.trim().starts_with("let v"))
            .count();
        assert_eq!(lets, tape.len());
        assert!(wgsl.contains(&format!("return v{};", tape.len() - 1)));
        // 2.5 exactly, by its bits.
        assert!(wgsl.contains("bitcast<f32>(0x40200000u)"), "{wgsl}");
    }

    #[test]
    fn constants_are_exact_bits_and_non_finite_ones_come_from_parameters() {
        assert_eq!(constant(1.0), "bitcast<f32>(0x3f800000u)");
        assert_eq!(constant(-0.0), "bitcast<f32>(0x80000000u)");
        assert_eq!(constant(f32::INFINITY), "inf_value()");
        assert_eq!(constant(f32::NEG_INFINITY), "-inf_value()");
        assert_eq!(constant(f32::NAN), "nan_value()");
        let tiny = f32::from_bits(1); // not a tolerance: the smallest subnormal's bits
        assert_eq!(constant(tiny), "bitcast<f32>(0x00000001u)");
    }

    #[test]
    fn every_op_has_its_own_wgsl() {
        let mut seen = std::collections::HashSet::new();
        for op in Unary::ALL {
            assert!(
                seen.insert(unary(op, "a")),
                "{op:?} repeats another op's code"
            );
        }
        for op in Binary::ALL {
            assert!(
                seen.insert(binary(op, "a", "b")),
                "{op:?} repeats another op's code"
            );
        }
    }

    #[test]
    fn the_parameter_struct_matches_the_shader_layout() {
        // Params is 48 bytes: vec3<u32> (12) + 9 u32 = 48, a multiple of 16.
        assert_eq!(std::mem::size_of::<Params>(), 48);
        let wgsl = shader(&tape_of("x var-x\n"));
        let fields = PRELUDE
            .split("struct Params {")
            .nth(1)
            .and_then(|s| s.split('}').next())
            .unwrap()
            .lines()
            .filter(|l| l.contains(':'))
            .count();
        // n, first, count, y_at, z_at, row, inf_bits, nan_bits, tile, tile_z.
        assert_eq!(fields, 10);
        for entry in ["grid_main", "points_main", "tiles_main"] {
            assert!(wgsl.contains(&format!("fn {entry}")), "{entry}");
        }
    }

    /// The shader parses and validates with naga (the WGSL front end wgpu uses),
    /// for a tape using every op: no GPU is needed.
    #[test]
    fn the_shader_of_every_op_validates() {
        let mut text = String::from("x var-x\ny var-y\nz var-z\n");
        let mut k = 0;
        for op in Unary::ALL {
            text.push_str(&format!("u{k} {} x\n", op.name()));
            k += 1;
        }
        for op in Binary::ALL {
            text.push_str(&format!("u{k} {} y z\n", op.name()));
            k += 1;
        }
        // Sum everything so every clause is live.
        text.push_str("s0 add u0 u1\n");
        for i in 2..k {
            text.push_str(&format!("s{} add s{} u{i}\n", i - 1, i - 2));
        }
        let tape = tape_of(&text);
        assert!(tape.len() >= k + 3);
        let wgsl = shader(&tape);
        let module = naga::front::wgsl::parse_str(&wgsl).unwrap_or_else(|e| {
            panic!("{}", e.emit_to_string(&wgsl));
        });
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{e:?}"));
    }
}
