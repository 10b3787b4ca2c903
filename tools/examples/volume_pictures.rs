//! The pictures of docs/volumes.md, one per application of the volume module (Park
//! 2005, sec. 5): a grid, streamlines, an isosurface and a morph strip, drawn by a
//! small orthographic rasteriser (lines and z-buffered, Lambert-shaded triangles)
//! into PNGs. It also writes the example input files the docs' commands run on.
//!
//! ```sh
//! cargo run -p sculpt-tools --example volume_pictures -- docs/images docs/examples/volume
//! ```
//!
//! The first argument is the folder for the pictures (`volume-grid.png`,
//! `volume-streamlines.png`, `volume-isosurface.png`, `volume-morph.png`), the second
//! the folder for the inputs (`flow.json`, `seeds.csv`, `sphere.json`, `a.png`,
//! `b.png`, `lines.json`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::{DMat3, DVec3};
use sculpt_core::volume::morph::{FeatureLine, FeatureLines, ImageMorph};
use sculpt_core::volume::{FlowField, PointArray, StreamlineOptions, StructuredGrid, Volume};

/// Picture size in pixels.
const W: usize = 480;
const H: usize = 360;

/// An RGB canvas with a depth buffer and an orthographic view.
struct Canvas {
    rgb: Vec<u8>,
    depth: Vec<f64>,
    /// World to view rotation (view x right, y up, z towards the viewer).
    view: DMat3,
    centre: DVec3,
    scale: f64,
}

impl Canvas {
    /// A white canvas looking at `centre` from yaw and pitch (degrees), `size` world
    /// units across the shorter side.
    fn new(centre: DVec3, size: f64, yaw: f64, pitch: f64) -> Self {
        let view =
            DMat3::from_rotation_x(pitch.to_radians()) * DMat3::from_rotation_y(yaw.to_radians());
        Self {
            rgb: vec![255; W * H * 3],
            depth: vec![f64::NEG_INFINITY; W * H],
            view,
            centre,
            scale: H.min(W) as f64 / size,
        }
    }

    /// Screen position (pixels) and depth of a world point (world z is up).
    fn project(&self, p: DVec3) -> DVec3 {
        // World z is up: swap to view y.
        let q = self.view
            * DVec3::new(
                p.x - self.centre.x,
                p.z - self.centre.z,
                -(p.y - self.centre.y),
            );
        DVec3::new(
            W as f64 / 2.0 + q.x * self.scale,
            H as f64 / 2.0 - q.y * self.scale,
            q.z,
        )
    }

    fn plot(&mut self, x: i64, y: i64, z: f64, c: [u8; 3]) {
        if x < 0 || y < 0 || x >= W as i64 || y >= H as i64 {
            return;
        }
        let i = y as usize * W + x as usize;
        if z >= self.depth[i] {
            self.depth[i] = z;
            self.rgb[i * 3..i * 3 + 3].copy_from_slice(&c);
        }
    }

    /// A world-space segment (depth-tested, a little in front so lines show on faces).
    fn line(&mut self, a: DVec3, b: DVec3, c: [u8; 3]) {
        let (pa, pb) = (self.project(a), self.project(b));
        let n = (pb - pa).truncate().abs().max_element().ceil().max(1.0) as usize;
        for s in 0..=n {
            let p = pa.lerp(pb, s as f64 / n as f64);
            // not a tolerance: lines drawn just in front of the faces they lie on
            self.plot(p.x.round() as i64, p.y.round() as i64, p.z + 1e-3, c);
        }
    }

    /// A polyline.
    fn polyline(&mut self, pts: &[DVec3], c: [u8; 3]) {
        for w in pts.windows(2) {
            self.line(w[0], w[1], c);
        }
    }

    /// A z-buffered triangle, Lambert-shaded by its normal against a light from the
    /// upper left front.
    fn triangle(&mut self, t: [DVec3; 3], base: [f64; 3]) {
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        let light = DVec3::new(-0.4, -0.5, 0.75).normalize();
        let shade = 0.25 + 0.75 * n.dot(self.view.transpose() * light).abs();
        let c = base.map(|b| (b * shade * 255.0).clamp(0.0, 255.0) as u8);
        let p = t.map(|v| self.project(v));
        let lo = p.iter().fold(DVec3::splat(f64::INFINITY), |a, q| a.min(*q));
        let hi = p
            .iter()
            .fold(DVec3::splat(f64::NEG_INFINITY), |a, q| a.max(*q));
        let area = (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[2].x - p[0].x) * (p[1].y - p[0].y);
        if area.abs() < f64::EPSILON {
            return;
        }
        for y in lo.y.floor().max(0.0) as i64..=hi.y.ceil().min(H as f64 - 1.0) as i64 {
            for x in lo.x.floor().max(0.0) as i64..=hi.x.ceil().min(W as f64 - 1.0) as i64 {
                let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
                let e = |a: DVec3, b: DVec3| (b.x - a.x) * (fy - a.y) - (fx - a.x) * (b.y - a.y);
                let (w0, w1, w2) = (
                    e(p[1], p[2]) / area,
                    e(p[2], p[0]) / area,
                    e(p[0], p[1]) / area,
                );
                if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                    self.plot(x, y, w0 * p[0].z + w1 * p[1].z + w2 * p[2].z, c);
                }
            }
        }
    }

    fn save(&self, path: &Path) -> Result<()> {
        image::RgbImage::from_raw(W as u32, H as u32, self.rgb.clone())
            .context("canvas size")?
            .save(path)
            .with_context(|| format!("{}: cannot write", path.display()))
    }
}

/// The geometry of `vol` at `u`.
fn at(vol: &Volume, u: [f64; 3]) -> Result<DVec3> {
    let p = vol.point(&u)?;
    Ok(DVec3::new(p[0], p[1], p[2]))
}

/// Draws the parameter lines `u_d` = const of the boundary faces of `vol`, `res`
/// lines per direction, in colour `c`.
fn draw_grid(cv: &mut Canvas, vol: &Volume, res: [usize; 3], c: [u8; 3]) -> Result<()> {
    let dom = vol.domain();
    let lerp = |d: usize, t: f64| dom[d].0 + (dom[d].1 - dom[d].0) * t;
    for along in 0..3 {
        let (a, b) = ((along + 1) % 3, (along + 2) % 3);
        for i in 0..=res[a] {
            for j in 0..=res[b] {
                let (ta, tb) = (i as f64 / res[a] as f64, j as f64 / res[b] as f64);
                // Only the lines on the boundary faces.
                if !(i == 0 || i == res[a] || j == 0 || j == res[b]) {
                    continue;
                }
                let mut pts = Vec::new();
                for s in 0..=64 {
                    let mut u = [0.0; 3];
                    u[along] = lerp(along, s as f64 / 64.0);
                    u[a] = lerp(a, ta);
                    u[b] = lerp(b, tb);
                    pts.push(at(vol, u)?);
                }
                cv.polyline(&pts, c);
            }
        }
    }
    Ok(())
}

/// A quarter cylindrical shell (radii 1 to 2.5, height 3) as a rational volume (the
/// one of docs/formats/volume.md), for the grid picture.
fn shell() -> Result<Volume> {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let mut values = Vec::new();
    let mut weights = Vec::new();
    for (c, w) in [([1.0, 0.0], 1.0), ([1.0, 1.0], s), ([0.0, 1.0], 1.0)] {
        for r in [1.0, 2.5] {
            for z in [0.0, 3.0] {
                values.extend([c[0] * r, c[1] * r, z]);
                weights.push(w);
            }
        }
    }
    Ok(Volume::new(
        vec![2, 1, 1],
        vec![
            vec![0., 0., 0., 1., 1., 1.],
            vec![0., 0., 1., 1.],
            vec![0., 0., 1., 1.],
        ],
        ["x", "y", "z"].map(String::from).to_vec(),
        values,
        Some(weights),
    )?)
}

/// A bent cube over `[-1, 1]^3` (cubic, 6^3 control points) carrying `fields` at its
/// control points.
fn bent_cube(names: &[&str], fields: impl Fn(DVec3) -> Vec<f64>) -> Result<Volume> {
    let c = 6;
    let knots = vec![0., 0., 0., 0., 1. / 3., 2. / 3., 1., 1., 1., 1.];
    let g = [0.0, 1. / 9., 1. / 3., 2. / 3., 8. / 9., 1.0];
    let mut values = Vec::new();
    for i in 0..c {
        for j in 0..c {
            for l in 0..c {
                let s = DVec3::new(g[i], g[j], g[l]) * 2.0 - DVec3::ONE;
                let p = s + 0.12 * DVec3::new((2.0 * s.z).sin(), 0.0, (1.5 * s.x).sin());
                values.extend([p.x, p.y, p.z]);
                values.extend(fields(p));
            }
        }
    }
    let mut attrs: Vec<String> = ["x", "y", "z"].map(String::from).to_vec();
    attrs.extend(names.iter().map(|s| s.to_string()));
    Ok(Volume::new(
        vec![3; 3],
        vec![knots.clone(), knots.clone(), knots],
        attrs,
        values,
        None,
    )?)
}

/// The flow of the streamline picture: a swirl about the z axis that spirals out and
/// rises (a focus at the axis), `V = (-y + 0.1 x, x + 0.1 y, 0.25)`.
fn flow() -> Result<Volume> {
    bent_cube(&["vx", "vy", "vz"], |p| {
        vec![-p.y + 0.1 * p.x, p.x + 0.1 * p.y, 0.25]
    })
}

/// Two 96 x 96 pictures to morph: a red disc and a blue bar.
fn morph_images() -> (Vec<u8>, Vec<u8>) {
    let n = 96;
    let mut a = Vec::with_capacity(n * n * 4);
    let mut b = Vec::with_capacity(n * n * 4);
    for y in 0..n {
        for x in 0..n {
            let (fx, fy) = (x as f64 - 30.0, y as f64 - 48.0);
            let disc = fx * fx + fy * fy < 18.0 * 18.0;
            a.extend(if disc {
                [220, 40, 40, 255]
            } else {
                [245, 240, 225, 255]
            });
            let bar = (60..76).contains(&x) && (16..80).contains(&y);
            b.extend(if bar {
                [40, 70, 200, 255]
            } else {
                [225, 235, 245, 255]
            });
        }
    }
    (a, b)
}

/// The lines of the morph picture: the disc's vertical diameter onto the bar's axis,
/// and its horizontal one onto the bar's width.
fn morph_lines() -> FeatureLines {
    FeatureLines {
        lines: vec![
            FeatureLine {
                source: [[30.0, 30.0], [30.0, 66.0]],
                target: [[68.0, 16.0], [68.0, 80.0]],
            },
            FeatureLine {
                source: [[12.0, 48.0], [48.0, 48.0]],
                target: [[60.0, 48.0], [76.0, 48.0]],
            },
        ],
        ..FeatureLines::default()
    }
}

fn main() -> Result<()> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [pictures, inputs] = args.as_slice() else {
        anyhow::bail!("usage: volume_pictures PICTURE_DIR INPUT_DIR");
    };
    std::fs::create_dir_all(pictures)?;
    std::fs::create_dir_all(inputs)?;

    // Grid generation (sec. 5.1): the quarter shell's uniform parameter grid.
    let vol = shell()?;
    let mut cv = Canvas::new(DVec3::new(1.1, 1.1, 1.5), 5.2, 35.0, 25.0);
    let dom = vol.domain();
    let res = [12, 4, 8];
    for i in 0..=res[0] {
        for j in 0..=res[1] {
            let mut pts = Vec::new();
            for k in 0..=res[2] {
                let u = [0, 1, 2].map(|d| {
                    dom[d].0 + (dom[d].1 - dom[d].0) * [i, j, k][d] as f64 / res[d] as f64
                });
                pts.push(at(&vol, u)?);
            }
            cv.polyline(&pts, [90, 90, 90]);
        }
    }
    draw_grid(&mut cv, &vol, res, [20, 60, 160])?;
    cv.save(&pictures.join("volume-grid.png"))?;

    // Streamlines (sec. 5.2).
    let vol = flow()?;
    std::fs::write(inputs.join("flow.json"), vol.to_json())?;
    let field = FlowField::new(&vol, [3, 4, 5])?;
    let inv = vol.inverter()?;
    let mut seeds_csv = String::from("x,y,z\n");
    let mut cv = Canvas::new(DVec3::ZERO, 3.0, 30.0, 28.0);
    draw_grid(&mut cv, &vol, [1, 1, 1], [150, 150, 150])?;
    for i in 0..24 {
        let a = i as f64 * 0.7;
        let r = 0.15 + 0.03 * i as f64;
        let seed = DVec3::new(r * a.cos(), r * a.sin(), -0.7);
        seeds_csv.push_str(&format!("{},{},{}\n", seed.x, seed.y, seed.z));
        let line = field.trace(inv.invert(seed)?, &StreamlineOptions::new(20.0))?;
        let t = i as f64 / 23.0;
        let c = [
            (40.0 + 200.0 * t) as u8,
            (90.0 + 60.0 * (1.0 - t)) as u8,
            (220.0 - 180.0 * t) as u8,
        ];
        cv.polyline(&line.points, c);
    }
    std::fs::write(inputs.join("seeds.csv"), seeds_csv)?;
    cv.save(&pictures.join("volume-streamlines.png"))?;

    // Isosurfaces (sec. 5.3): two spheres' distances, their union at level 0.45.
    let (c1, c2) = (DVec3::new(-0.3, 0.0, 0.1), DVec3::new(0.35, 0.1, -0.1));
    let grid_n = 13;
    let mut points = Vec::new();
    let mut dist = Vec::new();
    for l in 0..grid_n {
        for j in 0..grid_n {
            for i in 0..grid_n {
                let s = DVec3::new(i as f64, j as f64, l as f64) * (2.0 / (grid_n - 1) as f64)
                    - DVec3::ONE;
                let p = s + 0.08
                    * DVec3::new((2.0 * s.y).sin(), (2.0 * s.z).sin(), (2.0 * s.x).sin())
                    * (1.0 - s.length_squared() / 3.0);
                points.push(p.to_array());
                dist.push(p.distance(c1).min(p.distance(c2)));
            }
        }
    }
    let grid = StructuredGrid {
        dims: [grid_n; 3],
        points,
        arrays: vec![PointArray {
            name: "d".into(),
            components: 1,
            values: dist,
        }],
    };
    let (vol, _) = Volume::interpolate_grid(&grid, &[3, 3, 3])?;
    std::fs::write(inputs.join("sphere.json"), vol.to_json())?;
    let mesh = vol.isosurface(3, 0.45, [40; 3])?;
    let mut cv = Canvas::new(DVec3::ZERO, 2.2, 20.0, 20.0);
    for t in &mesh.triangles {
        let v = t.map(|i| DVec3::from_array(mesh.vertices[i as usize].position.map(f64::from)));
        cv.triangle(v, [0.95, 0.6, 0.3]);
    }
    cv.save(&pictures.join("volume-isosurface.png"))?;

    // Image morphing (sec. 5.4): five frames side by side.
    let (a, b) = morph_images();
    let lines = morph_lines();
    let m = ImageMorph::new((&a, 96, 96), (&b, 96, 96), lines.clone())?;
    let frames = 5;
    let mut strip = image::RgbaImage::new(96 * frames as u32, 96);
    for f in 0..frames {
        let img = m.frame(f as f64 / (frames - 1) as f64);
        let img = image::RgbaImage::from_raw(96, 96, img).context("frame size")?;
        image::imageops::replace(&mut strip, &img, 96 * f as i64, 0);
    }
    strip.save(pictures.join("volume-morph.png"))?;
    image::RgbaImage::from_raw(96, 96, a)
        .context("A")?
        .save(inputs.join("a.png"))?;
    image::RgbaImage::from_raw(96, 96, b)
        .context("B")?
        .save(inputs.join("b.png"))?;
    let json_lines: Vec<serde_json::Value> = lines
        .lines
        .iter()
        .map(|l| serde_json::json!({"source": l.source, "target": l.target}))
        .collect();
    let doc =
        serde_json::json!({"format": "wandsculpt-morph-lines", "version": 1, "lines": json_lines});
    std::fs::write(
        inputs.join("lines.json"),
        serde_json::to_string_pretty(&doc)? + "\n",
    )?;
    Ok(())
}
