//! A CPU ray caster of a document's exact geometry, for checking the GPU's pictures
//! without trusting the mesher or the renderer.
//!
//! The sculpted surface of a target is the displaced surface `X(uv) = S(uv) + h(uv) N(uv)`:
//! `S` the target NURBS, `N` its unit normal and `h` the strokes' combined height
//! (`sculpt_core::sculpt::tessellate::height`, the evaluation the scene tests in
//! `sculpt-core/tests/scenes.rs` check the mesh against). A ray `o + t d` meets it where
//! `f(t) = (q - S(uv)) . N(uv) - h(uv)` changes sign, `uv` being the certified closest
//! point of the target to `q = o + t d` (the target's inverter): near the surface, `q`
//! lies on the normal line of its closest point, so `f` is its height above the target
//! minus the sculpted height. `f` is continuous across rims and creases (where `h` only
//! has a kink), so bracketing and bisection find the hit without derivatives.
//!
//! Each pixel's ray is seeded by rasterising a fine grid of exact points `X` (the seed
//! only picks the surface and a parameter to start from; the hit is then solved on the
//! exact surface): the ray is marched through a window around the seed for the first
//! sign change of `f`, then bisected. A root counts as a hit when `q` lies on `X` within
//! [`HIT_RESIDUAL`] (this rejects the false roots beyond an open target's edge, where the
//! closest point is on the edge and `q - S` is not along the normal).

use glam::{DVec2, DVec3, DVec4};
use sculpt_core::sculpt::document::Document;
use sculpt_core::sculpt::surface::{ParamSurface, TargetSurface, normal_from};
use sculpt_core::sculpt::tessellate::height;
use sculpt_core::tolerance::{F32_EPS, POINT_EPS};
use vr_app::projection::EyeCamera;

/// Seed grid cells per side of each target's parameter square.
const SEED_GRID: usize = 256;
/// Steps of the march through the window around a seed.
const MARCH_STEPS: usize = 48;
/// A root is a hit when `q` lies within this distance (metres) of the sculpted surface:
/// float precision of the display frame.
const HIT_RESIDUAL: f64 = F32_EPS;

/// The exact view depth of every pixel of an eye image.
#[derive(Debug, Clone)]
pub struct ExactDepth {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Per pixel, rows from the top: the first hit of the ray through the pixel's
    /// centre, if any.
    pub hits: Vec<Option<Hit>>,
    /// Pixels with a seed whose ray found no root on the exact surface.
    pub unresolved: usize,
}

/// Where a pixel's ray meets the sculpted surface.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// The distance (metres) along the camera's view direction.
    pub depth: f64,
    /// The target hit (index in the document).
    pub target: usize,
    /// The parameter of the hit on the target.
    pub uv: DVec2,
    /// The ray's origin and unit direction.
    pub ray: (DVec3, DVec3),
}

impl ExactDepth {
    /// The depth at `(x, y)`.
    pub fn at(&self, x: u32, y: u32) -> Option<f64> {
        self.hit(x, y).map(|h| h.depth)
    }

    /// The hit at `(x, y)`.
    pub fn hit(&self, x: u32, y: u32) -> Option<Hit> {
        if x >= self.width || y >= self.height {
            return None;
        }
        self.hits[(y * self.width + x) as usize]
    }
}

/// How far (metres) the point at view depth `depth` on `hit`'s ray lies from the
/// sculpted surface, measured along the target's normal (as the scene tests measure a
/// mesh): `(q - S(uv)) . N(uv) - h(uv)` at the closest point `uv` of the target to `q`.
/// At grazing angles a small offset along the normal is a large one in depth, so this
/// is the measure a tessellation tolerance bounds.
pub fn offset_along_normal(doc: &Document, cam: &EyeCamera, hit: &Hit, depth: f64) -> f64 {
    let target = &doc.targets()[hit.target];
    let surface = target.target_surface();
    let strokes = doc.strokes_on(target.id);
    let (o, dir) = hit.ray;
    let forward = view_depth(cam, o + dir) - view_depth(cam, o);
    let q = o + dir * (depth / forward);
    let uv = surface.closest_point_from(q, hit.uv).uv_in_square;
    let (p, n, h) = sculpted(surface, &strokes, uv);
    (q - p).dot(n) - h
}

/// The sculpted point `X(uv)` of a target and its sculpted height.
fn sculpted(
    surface: &TargetSurface,
    strokes: &[sculpt_core::sculpt::tessellate::StrokeRef<'_>],
    uv: DVec2,
) -> (DVec3, DVec3, f64) {
    let sp = surface.eval(uv);
    let n = normal_from(surface, uv, &sp);
    let h = height(strokes, uv, sp.p);
    (sp.p, n, h)
}

/// Pixel coordinates (x right, y down, in pixels) and view depth of a display point.
fn to_pixel(cam: &EyeCamera, p: DVec3, width: u32, height: u32) -> Option<(f64, f64, f64)> {
    let clip = cam.clip_from_display() * p.extend(1.0);
    if clip.w <= 0.0 {
        return None;
    }
    let ndc = clip.truncate() / clip.w;
    let x = (ndc.x * 0.5 + 0.5) * f64::from(width);
    let y = (0.5 - ndc.y * 0.5) * f64::from(height);
    Some((x, y, view_depth(cam, p)))
}

/// Distance of `p` along the camera's view direction (what the GPU writes).
fn view_depth(cam: &EyeCamera, p: DVec3) -> f64 {
    -(cam.view_from_display * p.extend(1.0)).z
}

/// Per pixel: the nearest seed (view depth, target index, parameter).
type Seeds = Vec<Option<(f64, usize, DVec2)>>;
/// A seed grid point: its pixel position and view depth (when in front of the eye),
/// and its parameter.
type GridPoint = (Option<(f64, f64, f64)>, DVec2);

/// Rasterises the seed grid of target `k` into `seeds`.
fn rasterise_seeds(seeds: &mut Seeds, k: usize, grid: &[GridPoint], width: u32, height: u32) {
    let m = SEED_GRID + 1;
    let mut tri = |a: usize, b: usize, c: usize| {
        let (Some(pa), Some(pb), Some(pc)) = (grid[a].0, grid[b].0, grid[c].0) else {
            return;
        };
        let area = (pb.0 - pa.0) * (pc.1 - pa.1) - (pc.0 - pa.0) * (pb.1 - pa.1);
        if area.abs() <= POINT_EPS {
            return;
        }
        let x0 = pa.0.min(pb.0).min(pc.0).floor().max(0.0) as u32;
        let x1 = (pa.0.max(pb.0).max(pc.0).ceil() as u32).min(width);
        let y0 = pa.1.min(pb.1).min(pc.1).floor().max(0.0) as u32;
        let y1 = (pa.1.max(pb.1).max(pc.1).ceil() as u32).min(height);
        for y in y0..y1 {
            for x in x0..x1 {
                let (px, py) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
                let wa = ((pb.0 - px) * (pc.1 - py) - (pc.0 - px) * (pb.1 - py)) / area;
                let wb = ((pc.0 - px) * (pa.1 - py) - (pa.0 - px) * (pc.1 - py)) / area;
                let wc = 1.0 - wa - wb;
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let depth = wa * pa.2 + wb * pb.2 + wc * pc.2;
                let uv = grid[a].1 * wa + grid[b].1 * wb + grid[c].1 * wc;
                let slot = &mut seeds[(y * width + x) as usize];
                if slot.is_none_or(|(d, _, _)| depth < d) {
                    *slot = Some((depth, k, uv));
                }
            }
        }
    };
    for j in 0..SEED_GRID {
        for i in 0..SEED_GRID {
            let (a, b) = (j * m + i, j * m + i + 1);
            let (c, d) = (a + m, b + m);
            tri(a, b, d);
            tri(a, d, c);
        }
    }
}

/// Ray casts `doc`'s sculpted targets for `cam` at `width` x `height`.
pub fn cast(doc: &Document, cam: &EyeCamera, width: u32, height: u32) -> ExactDepth {
    let targets = doc.targets();
    let strokes: Vec<_> = targets.iter().map(|t| doc.strokes_on(t.id)).collect();
    let mut seeds: Seeds = vec![None; (width * height) as usize];
    // The march window around a seed: the deepest stroke twice over, plus the seed
    // grid's chord (a fraction of the target's size).
    let mut window: f64 = 0.0;
    for (k, t) in targets.iter().enumerate() {
        let surface = t.target_surface();
        let deepest = strokes[k]
            .iter()
            .map(|(_, s)| s.tool.depth)
            .fold(0.0, f64::max);
        window = window.max(2.0 * deepest + 4.0 * t.surface.size() / SEED_GRID as f64);
        let m = SEED_GRID + 1;
        let grid: Vec<GridPoint> = (0..m * m)
            .map(|idx| {
                let uv = DVec2::new(
                    (idx % m) as f64 / SEED_GRID as f64,
                    (idx / m) as f64 / SEED_GRID as f64,
                );
                let (p, n, h) = sculpted(surface, &strokes[k], uv);
                (to_pixel(cam, p + n * h, width, height), uv)
            })
            .collect();
        rasterise_seeds(&mut seeds, k, &grid, width, height);
    }
    let display_from_clip = cam.clip_from_display().inverse();
    let mut hits = vec![None; (width * height) as usize];
    let mut unresolved = 0;
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize;
            let Some((_, k, seed_uv)) = seeds[i] else {
                continue;
            };
            let ndc_x = (f64::from(x) + 0.5) / f64::from(width) * 2.0 - 1.0;
            let ndc_y = 1.0 - (f64::from(y) + 0.5) / f64::from(height) * 2.0;
            let near = display_from_clip * DVec4::new(ndc_x, ndc_y, 0.0, 1.0);
            let dir = (near.truncate() / near.w - cam.eye).normalize();
            let surface = targets[k].target_surface();
            match hit(surface, &strokes[k], cam.eye, dir, seed_uv, window) {
                Some((p, uv)) => {
                    hits[i] = Some(Hit {
                        depth: view_depth(cam, p),
                        target: k,
                        uv,
                        ray: (cam.eye, dir),
                    })
                }
                None => unresolved += 1,
            }
        }
    }
    ExactDepth {
        width,
        height,
        hits,
        unresolved,
    }
}

/// The first hit of the ray `o + t dir` on the sculpted target within `window` of the
/// seed's point and its parameter, or `None`.
fn hit(
    surface: &TargetSurface,
    strokes: &[sculpt_core::sculpt::tessellate::StrokeRef<'_>],
    o: DVec3,
    dir: DVec3,
    seed_uv: DVec2,
    window: f64,
) -> Option<(DVec3, DVec2)> {
    let (p, n, h) = sculpted(surface, strokes, seed_uv);
    let t0 = (p + n * h - o).dot(dir);
    let mut uv = seed_uv;
    // f(t) and the point's residual off the sculpted surface.
    let f = |t: f64, uv: &mut DVec2| {
        let q = o + dir * t;
        let pr = surface.closest_point_from(q, *uv);
        *uv = pr.uv_in_square;
        let (p, n, h) = sculpted(surface, strokes, pr.uv_in_square);
        let f = (q - p).dot(n) - h;
        (f, (q - (p + n * h)).length())
    };
    let step = 2.0 * window / MARCH_STEPS as f64;
    let mut t_prev = (t0 - window).max(0.0);
    let (mut f_prev, _) = f(t_prev, &mut uv);
    let mut uv_prev = uv;
    for s in 1..=MARCH_STEPS {
        let t = (t0 - window + step * s as f64).max(0.0);
        let (ft, _) = f(t, &mut uv);
        if f_prev.is_finite() && ft.is_finite() && (f_prev <= 0.0) != (ft <= 0.0) {
            // Bisect [t_prev, t] from the seed of its near end.
            let (mut lo, mut hi, mut f_lo) = (t_prev, t, f_prev);
            let mut uv_b = uv_prev;
            let mut residual = f64::INFINITY;
            while hi - lo > POINT_EPS {
                let mid = 0.5 * (lo + hi);
                let (fm, r) = f(mid, &mut uv_b);
                residual = r;
                if (fm <= 0.0) == (f_lo <= 0.0) {
                    (lo, f_lo) = (mid, fm);
                } else {
                    hi = mid;
                }
            }
            if residual <= HIT_RESIDUAL {
                return Some((o + dir * (0.5 * (lo + hi)), uv_b));
            }
        }
        (t_prev, f_prev, uv_prev) = (t, ft, uv);
    }
    None
}
