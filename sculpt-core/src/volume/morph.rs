//! Image morphing through a volume (Park 2005, sec. 5.4, eqs. 52 to 54).
//!
//! The two images `A` and `B` (RGBA, same size) are the ends of one trivariate volume
//! `I(u, v, w)` with attributes `r, g, b, a`: degree 1 in every direction, one control
//! point per pixel in `u` (column) and `v` (row), `A` at `w = 0` and `B` at `w = 1`.
//! `I(x, y, 0)` is `A` bilinearly interpolated between pixel centres (pixel `(i, j)` at
//! `u = i, v = j`), and `I` at a pixel centre is that pixel exactly.
//!
//! The warps `W^s` and `W^t` of eq. 53 are Beier and Neely's field morphing (Beier
//! and Neely, *Feature-based image metamorphosis*, SIGGRAPH 1992), in place of the
//! paper's mesh warp (eq. 52): every feature line `i` is a segment `P_i Q_i` in `A`
//! and `P'_i Q'_i` in `B`; at `w` its position is interpolated,
//! `L_i(w) = (1 - w) L_i^A + w L_i^B`. A frame pixel `X` has, for each line at `w`,
//! the coordinates `s = (X - P) . (Q - P) / |Q - P|^2` along and
//! `t = (X - P) . perp(Q - P) / |Q - P|` across it, which place it relative to the
//! line in `A` as `X_i = P^A + s (Q^A - P^A) + t perp(Q^A - P^A) / |Q^A - P^A|`; the
//! source point `X_A` is `X` plus the weighted mean of the displacements `X_i - X`,
//! with weights `(length^p / (a + dist))^b` (`dist` the distance from `X` to the
//! segment). `X_B` likewise against the lines in `B`.
//!
//! The frame at `w` is the cross-dissolve (eq. 54)
//! `M(X, w) = (1 - w) I(X_A, 0) + w I(X_B, 1)`, rounded to 8 bits. At `w = 0` the
//! lines are those of `A`, every displacement is zero (to rounding far below a
//! pixel) and the weight of `B` is zero, so frame 0 is `A`; the last frame is `B`.
//! Without lines the warp is the identity and the morph a plain cross-dissolve (the
//! paper's Fig. 6).
//!
//! The lines file (`docs/formats/morph-lines.md`):
//!
//! ```json
//! {"format": "wandsculpt-morph-lines", "version": 1, "a": 1.0, "b": 2.0, "p": 0.5,
//!  "lines": [{"source": [[x0, y0], [x1, y1]], "target": [[x0, y0], [x1, y1]]}]}
//! ```

use serde::Deserialize;
use thiserror::Error;

use super::{Volume, VolumeError};

/// The value of the lines file's `format` field.
pub const LINES_FORMAT: &str = "wandsculpt-morph-lines";
/// The lines file version this reader reads.
pub const LINES_VERSION: u64 = 1;
/// The most feature lines a file may hold (each is visited for every pixel).
pub const MAX_LINES: usize = 256;
/// The largest absolute coordinate of a line end, in pixels.
pub const MAX_COORD: f64 = 1e6;
/// The largest side of an image that can be morphed: the image volume holds one
/// control point per pixel and end ([`super::MAX_CONTROL_POINTS`]).
pub const MAX_SIDE: usize = 1024;
/// The shortest feature line, in pixels (a shorter one has no direction to speak of).
pub const MIN_LINE_LENGTH: f64 = 0.001;

/// Everything that can go wrong with a morph or its lines file.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum MorphError {
    /// The lines text is not JSON or not the schema.
    #[error("lines JSON: {0}")]
    Json(crate::error::JsonError),
    /// The `format` or `version` field is wrong.
    #[error(
        "lines JSON: expected \"format\": \"{LINES_FORMAT}\" and \"version\": {LINES_VERSION}, found {format:?} version {version}"
    )]
    FormatTag {
        /// The `format` found.
        format: String,
        /// The `version` found.
        version: u64,
    },
    /// Too many lines.
    #[error("{got} feature lines: at most {max}")]
    TooManyLines {
        /// Lines given.
        got: usize,
        /// The cap ([`MAX_LINES`]).
        max: usize,
    },
    /// A line end is not finite or too far out.
    #[error("line {line}, {which}: coordinate {value} is not finite within +-{max:e} pixels")]
    Coordinate {
        /// The line, 0-based.
        line: usize,
        /// `source` or `target`.
        which: &'static str,
        /// The value.
        value: f64,
        /// The cap ([`MAX_COORD`]).
        max: f64,
    },
    /// A line has (next to) zero length.
    #[error("line {line}, {which}: its ends are less than {MIN_LINE_LENGTH} pixels apart")]
    ZeroLength {
        /// The line, 0-based.
        line: usize,
        /// `source` or `target`.
        which: &'static str,
    },
    /// A weighting constant is out of range.
    #[error("{name} = {value}: {rule}")]
    Constant {
        /// `a`, `b` or `p`.
        name: &'static str,
        /// The value.
        value: f64,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// The two images differ in size.
    #[error("the images differ in size: {a_width}x{a_height} and {b_width}x{b_height}")]
    SizeMismatch {
        /// Width of A.
        a_width: usize,
        /// Height of A.
        a_height: usize,
        /// Width of B.
        b_width: usize,
        /// Height of B.
        b_height: usize,
    },
    /// An image is too small or too large, or its pixel buffer has the wrong length.
    #[error(
        "image {width}x{height} ({bytes} bytes): sides must be 2 to {max} pixels, 4 bytes per pixel"
    )]
    ImageSize {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Bytes given.
        bytes: usize,
        /// [`MAX_SIDE`].
        max: usize,
    },
    /// The image volume could not be built.
    #[error("image volume: {0}")]
    Volume(VolumeError),
}

/// One feature line: a segment in `A` and the corresponding segment in `B`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeatureLine {
    /// `[P, Q]` in image A, pixels (`x` right, `y` down, pixel centres at integers).
    pub source: [[f64; 2]; 2],
    /// `[P', Q']` in image B.
    pub target: [[f64; 2]; 2],
}

/// Feature lines and Beier and Neely's weighting constants.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureLines {
    /// The lines.
    pub lines: Vec<FeatureLine>,
    /// `a > 0`: how much a line holds the pixels right on it.
    pub a: f64,
    /// `b >= 0`: how fast a line's influence falls with distance.
    pub b: f64,
    /// `p >= 0`: how much longer lines weigh more.
    pub p: f64,
}

impl Default for FeatureLines {
    /// No lines (a plain cross-dissolve), `a = 1, b = 2, p = 0.5`.
    fn default() -> Self {
        Self {
            lines: Vec::new(),
            a: 1.0,
            b: 2.0,
            p: 0.5,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LinesJson {
    format: String,
    version: u64,
    #[serde(default)]
    a: Option<f64>,
    #[serde(default)]
    b: Option<f64>,
    #[serde(default)]
    p: Option<f64>,
    lines: Vec<FeatureLine>,
}

impl FeatureLines {
    /// Parses and checks a lines file.
    pub fn from_json(text: &str) -> Result<Self, MorphError> {
        let j: LinesJson = serde_json::from_str(text).map_err(|e| MorphError::Json(e.into()))?;
        if j.format != LINES_FORMAT || j.version != LINES_VERSION {
            return Err(MorphError::FormatTag {
                format: j.format,
                version: j.version,
            });
        }
        let d = Self::default();
        let out = Self {
            lines: j.lines,
            a: j.a.unwrap_or(d.a),
            b: j.b.unwrap_or(d.b),
            p: j.p.unwrap_or(d.p),
        };
        out.validate()?;
        Ok(out)
    }

    /// Checks the lines and constants.
    pub fn validate(&self) -> Result<(), MorphError> {
        if self.lines.len() > MAX_LINES {
            return Err(MorphError::TooManyLines {
                got: self.lines.len(),
                max: MAX_LINES,
            });
        }
        for (i, l) in self.lines.iter().enumerate() {
            for (which, seg) in [("source", &l.source), ("target", &l.target)] {
                for &value in seg.iter().flatten() {
                    if !(value.is_finite() && value.abs() <= MAX_COORD) {
                        return Err(MorphError::Coordinate {
                            line: i,
                            which,
                            value,
                            max: MAX_COORD,
                        });
                    }
                }
                let d = sub(seg[1], seg[0]);
                if dot(d, d).sqrt() < MIN_LINE_LENGTH {
                    return Err(MorphError::ZeroLength { line: i, which });
                }
            }
        }
        let checks = [
            (
                "a",
                self.a,
                self.a > 0.0 && self.a <= MAX_COORD,
                "a must be positive (and at most 1e6)",
            ),
            (
                "b",
                self.b,
                (0.0..=8.0).contains(&self.b),
                "b must lie in [0, 8]",
            ),
            (
                "p",
                self.p,
                (0.0..=8.0).contains(&self.p),
                "p must lie in [0, 8]",
            ),
        ];
        for (name, value, ok, rule) in checks {
            if !ok {
                return Err(MorphError::Constant { name, value, rule });
            }
        }
        Ok(())
    }
}

/// A point as `[x, y]`.
type P2 = [f64; 2];

fn sub(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}
fn dot(a: P2, b: P2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}
fn perp(a: P2) -> P2 {
    [-a[1], a[0]]
}
fn lerp(a: P2, b: P2, w: f64) -> P2 {
    [(1.0 - w) * a[0] + w * b[0], (1.0 - w) * a[1] + w * b[1]]
}

/// Beier and Neely's warp of the frame pixel `x` from the lines `now` (at the frame's
/// `w`) to the lines `to` (in one image): the source point in that image.
fn field_warp(x: P2, now: &[[P2; 2]], to: &[[P2; 2]], c: &FeatureLines) -> P2 {
    if now.is_empty() {
        return x;
    }
    let (mut sum, mut wsum) = ([0.0; 2], 0.0);
    for (l, m) in now.iter().zip(to) {
        let (p, q) = (l[0], l[1]);
        let pq = sub(q, p);
        let len2 = dot(pq, pq);
        let len = len2.sqrt();
        let xp = sub(x, p);
        let s = dot(xp, pq) / len2;
        let t = dot(xp, perp(pq)) / len;
        let mpq = sub(m[1], m[0]);
        let mlen = dot(mpq, mpq).sqrt();
        let mp = perp(mpq);
        let xi = [
            m[0][0] + s * mpq[0] + t * mp[0] / mlen,
            m[0][1] + s * mpq[1] + t * mp[1] / mlen,
        ];
        let dist = if s < 0.0 {
            dot(xp, xp).sqrt()
        } else if s > 1.0 {
            let xq = sub(x, q);
            dot(xq, xq).sqrt()
        } else {
            t.abs()
        };
        let weight = (len.powf(c.p) / (c.a + dist)).powf(c.b);
        sum[0] += (xi[0] - x[0]) * weight;
        sum[1] += (xi[1] - x[1]) * weight;
        wsum += weight;
    }
    let y = [x[0] + sum[0] / wsum, x[1] + sum[1] / wsum];
    // All weights underflowed (a pixel astronomically far from every line): no warp.
    if y[0].is_finite() && y[1].is_finite() {
        y
    } else {
        x
    }
}

/// Two images as the ends of a volume, and the lines that warp them (module docs).
#[derive(Debug, Clone)]
pub struct ImageMorph {
    width: usize,
    height: usize,
    volume: Volume,
    lines: FeatureLines,
}

impl ImageMorph {
    /// The morph from image `a` to image `b`, both RGBA8, row-major, `width` x
    /// `height` (given separately so that a size mismatch is named).
    pub fn new(
        a: (&[u8], usize, usize),
        b: (&[u8], usize, usize),
        lines: FeatureLines,
    ) -> Result<Self, MorphError> {
        let (pa, width, height) = a;
        let (pb, bw, bh) = b;
        if (width, height) != (bw, bh) {
            return Err(MorphError::SizeMismatch {
                a_width: width,
                a_height: height,
                b_width: bw,
                b_height: bh,
            });
        }
        for bytes in [pa.len(), pb.len()] {
            let ok_side = |s: usize| (2..=MAX_SIDE).contains(&s);
            if !ok_side(width) || !ok_side(height) || bytes != width * height * 4 {
                return Err(MorphError::ImageSize {
                    width,
                    height,
                    bytes,
                    max: MAX_SIDE,
                });
            }
        }
        lines.validate()?;
        // Degree 1 with knots at the pixel centres: the control point i sits at u = i.
        let axis = |count: usize| -> Vec<f64> {
            let mut k = vec![0.0];
            k.extend((0..count).map(|i| i as f64));
            k.push((count - 1) as f64);
            k
        };
        let mut values = Vec::with_capacity(width * height * 2 * 4);
        for i in 0..width {
            for j in 0..height {
                for img in [pa, pb] {
                    let at = (j * width + i) * 4;
                    values.extend(img[at..at + 4].iter().map(|&c| f64::from(c)));
                }
            }
        }
        let volume = Volume::new(
            vec![1, 1, 1],
            vec![axis(width), axis(height), vec![0.0, 0.0, 1.0, 1.0]],
            ["r", "g", "b", "a"].map(String::from).to_vec(),
            values,
            None,
        )
        .map_err(MorphError::Volume)?;
        Ok(Self {
            width,
            height,
            volume,
            lines,
        })
    }

    /// The image volume `I(u, v, w)` (attributes `r, g, b, a`).
    pub fn volume(&self) -> &Volume {
        &self.volume
    }

    /// The frame at `w` in `[0, 1]` (clamped): RGBA8, row-major (module docs).
    pub fn frame(&self, w: f64) -> Vec<u8> {
        let w = if w.is_nan() { 0.0 } else { w.clamp(0.0, 1.0) };
        let now: Vec<[P2; 2]> = self
            .lines
            .lines
            .iter()
            .map(|l| {
                [
                    lerp(l.source[0], l.target[0], w),
                    lerp(l.source[1], l.target[1], w),
                ]
            })
            .collect();
        let in_a: Vec<[P2; 2]> = self.lines.lines.iter().map(|l| l.source).collect();
        let in_b: Vec<[P2; 2]> = self.lines.lines.iter().map(|l| l.target).collect();
        let mut out = Vec::with_capacity(self.width * self.height * 4);
        let (mut ca, mut cb) = ([0.0; 4], [0.0; 4]);
        for j in 0..self.height {
            for i in 0..self.width {
                let x = [i as f64, j as f64];
                let xa = field_warp(x, &now, &in_a, &self.lines);
                let xb = field_warp(x, &now, &in_b, &self.lines);
                // The parameters are finite (the lines are), so evaluation cannot fail;
                // a failure would leave the colour black rather than panic.
                let _ = self.volume.eval_into(&[xa[0], xa[1], 0.0], &mut ca);
                let _ = self.volume.eval_into(&[xb[0], xb[1], 1.0], &mut cb);
                for c in 0..4 {
                    let v = (1.0 - w) * ca[c] + w * cb[c];
                    out.push(v.round().clamp(0.0, 255.0) as u8);
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With one line moved rigidly, the warp moves every pixel by the same offset
    /// (Beier and Neely: a single translated line translates the image).
    #[test]
    fn one_translated_line_translates() {
        let c = FeatureLines::default();
        let now = [[[10.0, 10.0], [20.0, 10.0]]];
        let to = [[[13.0, 8.0], [23.0, 8.0]]];
        for x in [[0.0, 0.0], [15.0, 30.0], [-4.0, 2.5]] {
            let y = field_warp(x, &now, &to, &c);
            crate::assert_near!(y[0], x[0] + 3.0, crate::tolerance::EXACT_EPS);
            crate::assert_near!(y[1], x[1] - 2.0, crate::tolerance::EXACT_EPS);
        }
    }
}
