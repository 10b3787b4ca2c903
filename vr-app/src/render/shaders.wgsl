// Wandsculpt scene and composition shaders.

struct Camera {
    clip_from_display: mat4x4<f32>,
    eye: vec4<f32>,
};

struct Material {
    color: vec4<f32>,
    wire_color: vec4<f32>,
};

@group(0) @binding(0) var<uniform> cam: Camera;
@group(1) @binding(0) var<uniform> mat: Material;

struct MeshIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
};

struct MeshOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) p_in_display: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

@vertex
fn vs_mesh(v: MeshIn) -> MeshOut {
    var o: MeshOut;
    o.clip = cam.clip_from_display * vec4<f32>(v.position, 1.0);
    o.p_in_display = v.position;
    o.normal = v.normal;
    return o;
}

@fragment
fn fs_mesh(f: MeshOut) -> @location(0) vec4<f32> {
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
    let key = normalize(vec3<f32>(0.35, 0.8, 0.5));
    let fill = normalize(vec3<f32>(-0.6, 0.2, 0.7));
    let diffuse = max(dot(n, key), 0.0) * 0.7 + max(dot(n, fill), 0.0) * 0.2;
    let h = normalize(key + to_eye);
    let spec = pow(max(dot(n, h), 0.0), 40.0) * 0.25;
    let sky = vec3<f32>(0.30, 0.33, 0.38);
    let ground = vec3<f32>(0.12, 0.10, 0.09);
    let ambient = mix(ground, sky, n.y * 0.5 + 0.5);
    let rgb = mat.color.rgb * (ambient + vec3<f32>(diffuse)) + vec3<f32>(spec);
    return vec4<f32>(clamp(rgb, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}

@vertex
fn vs_wire(v: MeshIn) -> @builtin(position) vec4<f32> {
    var c = cam.clip_from_display * vec4<f32>(v.position, 1.0);
    // Pull the wireframe slightly towards the eye so it wins the depth test.
    c.z = c.z - 2e-4 * c.w;
    return c;
}

@fragment
fn fs_wire() -> @location(0) vec4<f32> {
    return mat.wire_color;
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
fn fs_line(f: LineOut) -> @location(0) vec4<f32> {
    return f.color;
}

// ---- composition of the eye images into an output ----

struct Compose {
    mode: u32,
    half_width: u32,
    width: u32,
    height: u32,
};

@group(0) @binding(0) var left_eye: texture_2d<f32>;
@group(0) @binding(1) var right_eye: texture_2d<f32>;
@group(0) @binding(2) var<uniform> cmp: Compose;

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs_compose(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let xy = vec2<i32>(p.xy);
    switch cmp.mode {
        // 0: the first image alone (mono, or one projector of a dual setup).
        case 0u: {
            return textureLoad(left_eye, xy, 0);
        }
        // 1: side by side, first image on the left half.
        case 1u: {
            let h = i32(cmp.half_width);
            if (xy.x < h) {
                return textureLoad(left_eye, xy, 0);
            }
            return textureLoad(right_eye, vec2<i32>(xy.x - h, xy.y), 0);
        }
        // 2: red-cyan half-colour anaglyph.
        default: {
            let l = textureLoad(left_eye, xy, 0).rgb;
            let r = textureLoad(right_eye, xy, 0).rgb;
            let luma = dot(l, vec3<f32>(0.299, 0.587, 0.114));
            return vec4<f32>(luma, r.g, r.b, 1.0);
        }
    }
}

// ---- HUD text, in output pixels ----

struct Hud {
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
    return f.color;
}
