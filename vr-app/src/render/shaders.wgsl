// Wandsculpt scene and composition shaders.
//
// The eye passes write two images: the lit colour (an sRGB target: the shaders work
// in linear light and the hardware encodes) and a geometry image for the composition
// (view depth split into a half-float pair, coverage, surface class). Both are
// multisampled and resolved. The composition pass adds the cavity term and the
// silhouette outlines from the geometry image and encodes sRGB by hand when the
// output is not an sRGB format.

struct Camera {
    clip_from_display: mat4x4<f32>,
    view_from_display: mat4x4<f32>,
    eye: vec4<f32>,
};

struct Material {
    albedo: vec4<f32>,
    wire_color: vec4<f32>,
    // x specular strength, y exponent, z pattern (0 none, 1 speckle, 2 rings), w class.
    params: vec4<f32>,
};

@group(0) @binding(0) var<uniform> cam: Camera;
@group(1) @binding(0) var<uniform> mat: Material;

// The paint over the document (render/paint_texture.rs): a 3D texture of the tint,
// premultiplied by coverage, over a box of the display frame.
struct PaintBox {
    // The box's least corner; w is 1 with paint, 0 without.
    lo: vec4<f32>,
    inv_size: vec4<f32>,
};

@group(2) @binding(0) var paint_tex: texture_3d<f32>;
@group(2) @binding(1) var paint_sampler: sampler;
@group(2) @binding(2) var<uniform> paint_box: PaintBox;

// The premultiplied paint at a display point: (r a, g a, b a, a), zero outside the box.
fn paint_at(p: vec3<f32>) -> vec4<f32> {
    let s = (p - paint_box.lo.xyz) * paint_box.inv_size.xyz;
    if (paint_box.lo.w < 0.5 || any(s < vec3<f32>(0.0)) || any(s > vec3<f32>(1.0))) {
        return vec4<f32>(0.0);
    }
    return textureSampleLevel(paint_tex, paint_sampler, s, 0.0);
}

struct MeshIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
};

struct MeshOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) p_in_display: vec3<f32>,
    @location(1) normal: vec3<f32>,
    // The vertex's n n^T (diagonal, then xy, xz, yz) and (v . n) n, interpolated: the
    // terms of the curved-surface point (`curved_point`).
    @location(2) nn_diag: vec3<f32>,
    @location(3) nn_off: vec3<f32>,
    @location(4) vn_n: vec3<f32>,
};

struct SceneOut {
    @location(0) color: vec4<f32>,
    @location(1) geom: vec4<f32>,
};

@vertex
fn vs_mesh(v: MeshIn) -> MeshOut {
    var o: MeshOut;
    o.clip = cam.clip_from_display * vec4<f32>(v.position, 1.0);
    o.p_in_display = v.position;
    o.normal = v.normal;
    let n = v.normal;
    o.nn_diag = n * n;
    o.nn_off = vec3<f32>(n.x * n.y, n.x * n.z, n.y * n.z);
    o.vn_n = dot(v.position, n) * n;
    return o;
}

// The point of the smooth surface over a fragment of a flat triangle: Phong
// tessellation (Boubekeur and Alexa, "Phong Tessellation", SIGGRAPH Asia 2008, eq. 1-2)
// with shape factor 1/2, p* = p + 1/2 sum_i b_i ((v_i - p) . n_i) n_i, where b_i are
// p's barycentric coordinates and v_i, n_i the corners and their (exact) normals. The
// sum is sum_i b_i (v_i . n_i) n_i - (sum_i b_i n_i n_i^T) p, i.e. the interpolated
// vertex outputs `vn_n`, `nn_diag` and `nn_off`. For a surface z = x^T H x / 2 over its
// tangent plane, sum_i b_i ((v_i - p) . n_i) n_i is twice the surface's height above
// the flat triangle to first order in the slope, so the factor 1/2 puts p* on the
// surface: the chord error (up to the tessellation tolerance) leaves the depth that
// the cavity term reads, and the facets' creases with it.
fn curved_point(f: MeshOut) -> vec3<f32> {
    let p = f.p_in_display;
    let d = f.nn_diag;
    let o = f.nn_off;
    let m_p = vec3<f32>(
        d.x * p.x + o.x * p.y + o.y * p.z,
        o.x * p.x + d.y * p.y + o.z * p.z,
        o.y * p.x + o.z * p.y + d.z * p.z,
    );
    return p + 0.5 * (f.vn_n - m_p);
}

fn hash3(p: vec3<f32>) -> f32 {
    let q = fract(p * vec3<f32>(0.1031, 0.1030, 0.0973));
    let r = q + dot(q, q.yzx + 33.33);
    return fract((r.x + r.y) * r.z);
}

// Value noise on the integer lattice, smoothly interpolated.
fn noise3(p: vec3<f32>) -> f32 {
    let i = floor(p);
    let f = fract(p);
    let u = f * f * (3.0 - 2.0 * f);
    let a = mix(hash3(i), hash3(i + vec3<f32>(1.0, 0.0, 0.0)), u.x);
    let b = mix(hash3(i + vec3<f32>(0.0, 1.0, 0.0)), hash3(i + vec3<f32>(1.0, 1.0, 0.0)), u.x);
    let c = mix(hash3(i + vec3<f32>(0.0, 0.0, 1.0)), hash3(i + vec3<f32>(1.0, 0.0, 1.0)), u.x);
    let d = mix(hash3(i + vec3<f32>(0.0, 1.0, 1.0)), hash3(i + vec3<f32>(1.0, 1.0, 1.0)), u.x);
    return mix(mix(a, b, u.y), mix(c, d, u.y), u.z);
}

fn albedo_at(p: vec3<f32>) -> vec3<f32> {
    let base = mat.albedo.rgb;
    if (mat.params.z > 1.5) {
        // Wood: growth rings around a vertical axis, disturbed by noise.
        let r = length(p.xz - vec2<f32>(0.13, -0.4)) * 90.0 + noise3(p * 40.0) * 2.5;
        let ring = smoothstep(0.0, 0.35, fract(r)) * (1.0 - smoothstep(0.55, 1.0, fract(r)));
        return base * (0.72 + 0.28 * ring);
    }
    if (mat.params.z > 0.5) {
        // Stone: a fine speckle over a slow mottle.
        let s = noise3(p * 900.0) * 0.6 + noise3(p * 60.0) * 0.4;
        return base * (0.82 + 0.3 * s);
    }
    return base;
}

// The view depth (metres along the view direction) as a pair of half floats whose sum
// is exact to about 20 bits; resolve averages both. The high part lies on a grid of
// 2^(e - 8) for a depth in [2^e, 2^(e+1)), 4 half-float ulps: the average of up to 4
// samples' high parts (the renderer's most) is then a multiple of one ulp, which the
// half-float resolve target holds exactly. (Rounded to the nearest half float instead, two fragments on
// either side of a triangle edge could round to neighbouring halves, and their average,
// rounded again, was off by up to half an ulp, 0.5 mm at 1.5 m: single pixels along
// patch edges that the cavity term turned into bright dots.) The low part, at most
// 2^(e - 9), keeps the rest to a micrometre at 1 m.
fn geometry(p_in_display: vec3<f32>, class_id: f32) -> vec4<f32> {
    let d = -(cam.view_from_display * vec4<f32>(p_in_display, 1.0)).z;
    let q = exp2(floor(log2(max(d, 1e-6))) - 8.0);
    let hi = round(d / q) * q;
    return vec4<f32>(hi, d - hi, 1.0, class_id);
}

@fragment
fn fs_mesh(f: MeshOut) -> SceneOut {
    let to_eye = normalize(cam.eye.xyz - f.p_in_display);
    var n = f.normal;
    if (dot(n, n) < 1e-12) {
        n = to_eye;
    }
    n = normalize(n);
    // Two-sided: light the side that faces the eye.
    if (dot(n, to_eye) < 0.0) {
        n = -n;
    }
    // Lights are fixed to the viewer: a key from the upper left, a weak rim from the
    // lower right, and a sky/ground hemisphere.
    let n_view = normalize((cam.view_from_display * vec4<f32>(n, 0.0)).xyz);
    let v_view = normalize((cam.view_from_display * vec4<f32>(to_eye, 0.0)).xyz);
    let key = normalize(vec3<f32>(-0.45, 0.65, 0.62));
    let rim = normalize(vec3<f32>(0.7, -0.3, 0.25));
    let diffuse = max(dot(n_view, key), 0.0) * 1.1 + max(dot(n_view, rim), 0.0) * 0.12;
    let sky = vec3<f32>(0.34, 0.37, 0.43);
    let ground = vec3<f32>(0.10, 0.09, 0.08);
    let hemi = mix(ground, sky, n_view.y * 0.5 + 0.5);
    let h = normalize(key + v_view);
    let spec = pow(max(dot(n_view, h), 0.0), mat.params.y) * mat.params.x
        * step(0.0, dot(n_view, key));
    // Paint over the material by its coverage, before lighting.
    let paint = paint_at(f.p_in_display);
    let albedo = albedo_at(f.p_in_display) * (1.0 - paint.a) + paint.rgb;
    let rgb = albedo * (hemi + vec3<f32>(diffuse)) + vec3<f32>(spec);
    var o: SceneOut;
    o.color = vec4<f32>(clamp(rgb, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
    o.geom = geometry(curved_point(f), mat.params.w);
    return o;
}

@vertex
fn vs_wire(v: MeshIn) -> @builtin(position) vec4<f32> {
    var c = cam.clip_from_display * vec4<f32>(v.position, 1.0);
    // Pull the wireframe slightly towards the eye so it wins the depth test.
    c.z = c.z - 2e-4 * c.w;
    return c;
}

// Overlays (wireframe, lines) write class 0 into the geometry image's alpha only
// (their pipelines mask the other channels): no cavity or outline on them.
@fragment
fn fs_wire() -> SceneOut {
    var o: SceneOut;
    o.color = mat.wire_color;
    o.geom = vec4<f32>(0.0);
    return o;
}

struct LineIn {
    @location(0) position: vec3<f32>,
    @location(1) color: vec4<f32>,
};

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
};

@vertex
fn vs_line(v: LineIn) -> LineOut {
    var o: LineOut;
    o.clip = cam.clip_from_display * vec4<f32>(v.position, 1.0);
    o.clip.z = o.clip.z - 4e-4 * o.clip.w;
    o.color = v.color;
    return o;
}

@fragment
fn fs_line(f: LineOut) -> SceneOut {
    var o: SceneOut;
    o.color = f.color;
    o.geom = vec4<f32>(0.0);
    return o;
}

// The parts of the cursor behind a surface: drawn through it, fainter.
@fragment
fn fs_line_hidden(f: LineOut) -> SceneOut {
    var o: SceneOut;
    o.color = vec4<f32>(f.color.rgb, f.color.a * 0.45);
    o.geom = vec4<f32>(0.0);
    return o;
}

// ---- composition of the eye images into an output ----

struct Compose {
    mode: u32,
    half_width: u32,
    width: u32,
    height: u32,
    // 1: encode sRGB here (the output is not an sRGB format).
    encode_srgb: u32,
    // 1: cavity shading and outlines on.
    effects: u32,
    // Pixels per metre at one metre of view depth (the projection's focal length).
    focal_px: f32,
    pad: f32,
};

@group(0) @binding(0) var left_eye: texture_2d<f32>;
@group(0) @binding(1) var right_eye: texture_2d<f32>;
@group(0) @binding(2) var<uniform> cmp: Compose;
@group(0) @binding(3) var left_geom: texture_2d<f32>;
@group(0) @binding(4) var right_geom: texture_2d<f32>;

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

// Radius (metres) of the cavity neighbourhood, the depth (metres) at which a
// neighbour counts as fully occluding, and the depth beyond which it is ignored (a
// separate object in front, not the wall of a groove).
const CAVITY_RADIUS_M: f32 = 0.006;
const CAVITY_FULL_M: f32 = 0.003;
const CAVITY_RANGE_M: f32 = 0.02;
const CAVITY_STRENGTH: f32 = 1.0;
// A neighbour this much farther (fraction of the depth) is across a silhouette.
const SILHOUETTE_JUMP: f32 = 0.04;

struct Geo {
    depth: f32,
    coverage: f32,
    class_id: f32,
};

fn geo_at(t: texture_2d<f32>, xy: vec2<i32>) -> Geo {
    let size = vec2<i32>(textureDimensions(t));
    let g = textureLoad(t, clamp(xy, vec2<i32>(0), size - 1), 0);
    var o: Geo;
    o.coverage = g.b;
    if (g.b > 0.01) {
        o.depth = (g.r + g.g) / g.b;
        o.class_id = g.a / g.b;
    } else {
        o.depth = 1e9;
        o.class_id = 0.0;
    }
    return o;
}

// Cavity shading by unsharp masking the depth buffer (Luft, Colditz and Deussen,
// "Image enhancement by unsharp masking the depth buffer", SIGGRAPH 2006): where the
// neighbourhood within CAVITY_RADIUS_M lies nearer the eye than the pixel (the bottom
// and walls of a groove), the pixel darkens. A flat or convex surface has no nearer
// neighbourhood and is untouched. Then a dark outline where the pixel's surface is in
// front of a much deeper one or of the background, and an amber one around the
// selected target.
fn shade(color: vec4<f32>, geom: texture_2d<f32>, xy: vec2<i32>) -> vec4<f32> {
    if (cmp.effects == 0u) {
        return color;
    }
    let c = geo_at(geom, xy);
    if (c.coverage < 0.5 || c.class_id < 0.5) {
        return color;
    }
    let r = clamp(CAVITY_RADIUS_M * cmp.focal_px / max(c.depth, 1e-3), 1.5, 24.0);
    var occlusion = 0.0;
    var taps = 0.0;
    for (var k = 0; k < 12; k = k + 1) {
        let a = f32(k) * 0.5235988 + 0.2;
        let rk = select(r, r * 0.5, (k & 1) == 1);
        let off = vec2<i32>(round(vec2<f32>(cos(a), sin(a)) * rk));
        let nb = geo_at(geom, xy + off);
        if (nb.coverage < 0.5 || nb.class_id < 0.5) {
            continue;
        }
        let nearer = c.depth - nb.depth;
        let w = 1.0 - smoothstep(CAVITY_RANGE_M * 0.5, CAVITY_RANGE_M, abs(nearer));
        occlusion = occlusion + clamp(nearer / CAVITY_FULL_M, 0.0, 1.0) * w;
        taps = taps + 1.0;
    }
    var rgb = color.rgb;
    if (taps > 0.0) {
        rgb = rgb * (1.0 - CAVITY_STRENGTH * occlusion / taps);
    }
    var edge = 0.0;
    var selected_edge = 0.0;
    let is_selected = abs(c.class_id - 3.0) < 0.5;
    var dirs = array<vec2<i32>, 4>(vec2<i32>(1, 0), vec2<i32>(-1, 0), vec2<i32>(0, 1), vec2<i32>(0, -1));
    for (var k = 0; k < 4; k = k + 1) {
        let nb = geo_at(geom, xy + dirs[k]);
        if (nb.coverage < 0.5 || nb.depth - c.depth > SILHOUETTE_JUMP * c.depth) {
            edge = 1.0;
        }
        if (is_selected && abs(nb.class_id - 3.0) >= 0.5) {
            selected_edge = 1.0;
        }
    }
    rgb = mix(rgb, vec3<f32>(0.01, 0.012, 0.015), edge * 0.7);
    rgb = mix(rgb, vec3<f32>(1.0, 0.45, 0.02), selected_edge);
    return vec4<f32>(rgb, color.a);
}

fn srgb_encode(c: vec3<f32>) -> vec3<f32> {
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    let lo = x * 12.92;
    let hi = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, x <= vec3<f32>(0.0031308));
}

fn finish(c: vec4<f32>) -> vec4<f32> {
    if (cmp.encode_srgb == 1u) {
        return vec4<f32>(srgb_encode(c.rgb), c.a);
    }
    return c;
}

@fragment
fn fs_compose(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let xy = vec2<i32>(p.xy);
    switch cmp.mode {
        // 0: the first image alone (mono, or one projector of a dual setup).
        case 0u: {
            return finish(shade(textureLoad(left_eye, xy, 0), left_geom, xy));
        }
        // 1: side by side, first image on the left half.
        case 1u: {
            let h = i32(cmp.half_width);
            if (xy.x < h) {
                return finish(shade(textureLoad(left_eye, xy, 0), left_geom, xy));
            }
            let q = vec2<i32>(xy.x - h, xy.y);
            return finish(shade(textureLoad(right_eye, q, 0), right_geom, q));
        }
        // 2: red-cyan half-colour anaglyph.
        default: {
            let l = finish(shade(textureLoad(left_eye, xy, 0), left_geom, xy)).rgb;
            let r = finish(shade(textureLoad(right_eye, xy, 0), right_geom, xy)).rgb;
            let luma = dot(l, vec3<f32>(0.299, 0.587, 0.114));
            return vec4<f32>(luma, r.g, r.b, 1.0);
        }
    }
}

// ---- HUD text, in output pixels ----

struct Hud {
    // width, height, encode sRGB (1) or not (0), unused.
    size: vec4<f32>,
};

@group(0) @binding(0) var<uniform> hud: Hud;

struct HudIn {
    @location(0) pixel: vec2<f32>,
    @location(1) color: vec4<f32>,
};

@vertex
fn vs_hud(v: HudIn) -> LineOut {
    var o: LineOut;
    let ndc = vec2<f32>(v.pixel.x / hud.size.x * 2.0 - 1.0, 1.0 - v.pixel.y / hud.size.y * 2.0);
    o.clip = vec4<f32>(ndc, 0.0, 1.0);
    o.color = v.color;
    return o;
}

@fragment
fn fs_hud(f: LineOut) -> @location(0) vec4<f32> {
    if (hud.size.z > 0.5) {
        return vec4<f32>(srgb_encode(f.color.rgb), f.color.a);
    }
    return f.color;
}
