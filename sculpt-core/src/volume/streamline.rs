//! Streamlines of a velocity attribute (Park 2005, sec. 5.2, eqs. 44 to 49).
//!
//! A trivariate volume carries the geometry `B(u)` (eq. 44) and, among its other
//! attributes `D(u)` (eq. 45), a velocity `V = (v_x, v_y, v_z)` in physical space. A
//! particle `x(t)` with `dx/dt = V(x)` is traced in parameter space instead, where no
//! point location is needed: since `x = B(u)`,
//!
//! `du_i / dt = grad u_i . V` (eq. 49),
//!
//! the contravariant components of the velocity, with the contravariant base vectors
//! `grad u_i` of sec. 4 (eq. 32). Every right-hand side is one evaluation of the
//! volume with its first derivatives ([`Volume::eval_d1_into`]).
//!
//! The integrator is the embedded Runge-Kutta pair of Dormand and Prince, order 5
//! with an order-4 error estimate (Dormand and Prince, *A family of embedded
//! Runge-Kutta formulae*, J. Comp. Appl. Math. 6, 1980; the tableau of Hairer,
//! Norsett and Wanner, *Solving Ordinary Differential Equations I*, sec. II.5,
//! table 5.2): seven stages, the last one the first of the next step (FSAL), the
//! fifth-order solution kept (local extrapolation). The error of a step is
//! `max_i |e_i| / (tol * width_i)`, `width_i` the parameter domain's width in
//! direction `i`; a step is accepted when it is at most 1 and the next step is
//! `h * min(5, max(0.2, 0.9 err^(-1/5)))` (HNW II.4, eq. 4.13).
//!
//! A step that would leave the parameter domain is shortened in proportion to the part
//! of its chord inside, and retried, until it ends within
//! [`STREAMLINE_BOUNDARY_REL`] of a face: the line then ends there
//! ([`StreamlineEnd::Boundary`]).

use glam::DVec3;

use super::{Volume, VolumeResult};
use crate::tolerance::{STREAMLINE_BOUNDARY_REL, STREAMLINE_STEP_REL};

/// The Dormand-Prince 5(4) nodes `c_i` (HNW II.5, table 5.2); the field is
/// autonomous, so only the tableau's consistency test reads them.
#[cfg(test)]
const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
/// The Dormand-Prince 5(4) coupling coefficients `a_ij`, row `i` (stages 2 to 7).
const A: [[f64; 6]; 6] = [
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// The error weights `b_i - b*_i` (fifth-order minus fourth-order weights).
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];
/// Retries of one step shortened towards the boundary before the line is clamped
/// onto it.
const BOUNDARY_TRIES: usize = 60;

/// Why a streamline ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamlineEnd {
    /// It was traced for the whole time asked for.
    Time,
    /// It reached the boundary of the volume.
    Boundary,
    /// It took the most steps allowed.
    MaxSteps,
    /// The map is singular (or the velocity not finite) where it went next; the
    /// line ends at its last good point.
    Singular,
    /// The step size fell below the resolution of the time.
    StepUnderflow,
}

/// How to trace a streamline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamlineOptions {
    /// The time to trace for (negative: backwards, against the velocity).
    pub time: f64,
    /// The local error allowed per step, relative to the domain's width.
    pub tolerance: f64,
    /// The most accepted steps (bounds the memory of one line).
    pub max_steps: usize,
}

impl StreamlineOptions {
    /// Tracing for `time`, with [`STREAMLINE_STEP_REL`] and at most 100,000 steps.
    pub fn new(time: f64) -> Self {
        Self {
            time,
            tolerance: STREAMLINE_STEP_REL,
            max_steps: 100_000,
        }
    }
}

/// A traced streamline.
#[derive(Debug, Clone, PartialEq)]
pub struct Streamline {
    /// The parameters of every point, the seed first.
    pub params: Vec<[f64; 3]>,
    /// The physical points `B(u)`, one per parameter.
    pub points: Vec<DVec3>,
    /// The time reached (of the same sign as the time asked for).
    pub time: f64,
    /// Why it ended.
    pub end: StreamlineEnd,
}

/// The velocity attributes of a trivariate volume with geometry, ready for tracing.
///
/// It keeps its own copy of the volume with only the six attributes it reads, the
/// velocity first and `x, y, z` last: evaluation costs in proportion to the attributes
/// (a flow data set carries more: density, energy, pressure, `k = 8` in the paper), and
/// only the geometry is differentiated ([`Volume::eval_d1_last3_into`]).
#[derive(Debug, Clone)]
pub struct FlowField {
    vol: Volume,
    lo: [f64; 3],
    hi: [f64; 3],
}

/// One evaluation of the right-hand side: `du/dt` and the physical point.
type Rhs = ([f64; 3], DVec3);

impl FlowField {
    /// The scratch [`Self::param_velocity`] needs: the six values and the three
    /// derivatives of the geometry in each of three directions.
    pub const ROW: usize = 6 + 3 * 3;

    /// The flow of the velocity attributes `velocity` (three attribute indices) of
    /// `vol`, which must be trivariate with geometry `x, y, z`.
    pub fn new(vol: &Volume, velocity: [usize; 3]) -> VolumeResult<Self> {
        let geometry = vol.geometry3("streamlines")?;
        for &v in &velocity {
            vol.check_attribute(v)?;
        }
        let domain = vol.domain();
        let picked = [
            velocity[0],
            velocity[1],
            velocity[2],
            geometry[0],
            geometry[1],
            geometry[2],
        ];
        Ok(Self {
            vol: vol.with_attributes(&picked)?,
            lo: std::array::from_fn(|d| domain[d].0),
            hi: std::array::from_fn(|d| domain[d].1),
        })
    }

    /// The contravariant velocity `du_i/dt = grad u_i . V` (eq. 49) at `u` and the
    /// point `B(u)`; `row` is scratch of [`Self::ROW`] values.
    ///
    /// With the cross products `c_i` of the covariant base vectors
    /// ([`Frame::jacobian`](super::Frame)), `grad u_i = c_i / sqrt(g)` (eq. 32), so
    /// `du_i/dt = (c_i . V) / sqrt(g)`: one division for the three components.
    pub fn param_velocity(&self, u: &[f64; 3], row: &mut [f64]) -> VolumeResult<Rhs> {
        // The velocity's values, the geometry's, then dB/du_1, dB/du_2, dB/du_3.
        self.vol.eval_d1_last3_into(u, row)?;
        let at = |i: usize| DVec3::new(row[i], row[i + 1], row[i + 2]);
        let (jacobian, cross) = super::Frame::jacobian(u, [at(6), at(9), at(12)])?;
        let v = at(0);
        let inv = 1.0 / jacobian;
        let du = [
            cross[0].dot(v) * inv,
            cross[1].dot(v) * inv,
            cross[2].dot(v) * inv,
        ];
        if du.iter().all(|x| x.is_finite()) {
            Ok((du, at(3)))
        } else {
            Err(super::VolumeError::SingularJacobian {
                params: u.to_vec(),
                jacobian,
            })
        }
    }

    /// Traces the streamline from the parameters `seed` (clamped into the domain)
    /// for `opts.time` (module docs). Fails only when the seed itself is bad (not
    /// finite, or a singular map there); trouble later ends the line
    /// ([`StreamlineEnd`]).
    pub fn trace(&self, seed: [f64; 3], opts: &StreamlineOptions) -> VolumeResult<Streamline> {
        self.vol.check_params(&seed)?;
        let mut row = [0.0; Self::ROW];
        let width: [f64; 3] = std::array::from_fn(|d| self.hi[d] - self.lo[d]);
        let mut u: [f64; 3] = std::array::from_fn(|d| seed[d].clamp(self.lo[d], self.hi[d]));
        let sign = if opts.time < 0.0 { -1.0 } else { 1.0 };
        let total = opts.time.abs();
        let tol = if opts.tolerance > 0.0 {
            opts.tolerance
        } else {
            STREAMLINE_STEP_REL
        };
        let (k1, p0) = self.param_velocity(&u, &mut row)?;
        let mut k1 = k1.map(|x| x * sign);
        let mut line = Streamline {
            params: vec![u],
            points: vec![p0],
            time: 0.0,
            end: StreamlineEnd::Time,
        };
        // Starting step: a fifth-root of the tolerance of the domain per unit speed.
        let speed = (0..3).map(|d| k1[d].abs() / width[d]).fold(0.0, f64::max);
        let mut h = if speed > 0.0 {
            (tol.powf(0.2) / speed).min(total)
        } else {
            total
        };
        let mut t = 0.0;
        let mut steps = 0;
        let mut boundary_tries = 0;
        let mut k = [[0.0; 3]; 7];
        loop {
            let remaining = total - t;
            if remaining <= 0.0 || !total.is_finite() {
                line.end = StreamlineEnd::Time;
                break;
            }
            if steps >= opts.max_steps {
                line.end = StreamlineEnd::MaxSteps;
                break;
            }
            h = h.min(remaining);
            if t + h == t || h <= 0.0 {
                line.end = StreamlineEnd::StepUnderflow;
                break;
            }
            // The stages (k[0] is the last step's final stage, FSAL).
            k[0] = k1;
            let mut end_point = DVec3::ZERO;
            let mut failed = false;
            for s in 1..7 {
                let us: [f64; 3] = std::array::from_fn(|d| {
                    u[d] + h * (0..s).map(|j| A[s - 1][j] * k[j][d]).sum::<f64>()
                });
                match self.param_velocity(&us, &mut row) {
                    Ok((ks, p)) => {
                        k[s] = ks.map(|x| x * sign);
                        end_point = p;
                    }
                    Err(_) => {
                        failed = true;
                        break;
                    }
                }
            }
            if failed {
                // A singular stage: try a shorter step before giving up.
                h *= 0.25;
                if h < f64::EPSILON * total {
                    line.end = StreamlineEnd::Singular;
                    break;
                }
                continue;
            }
            // The fifth-order solution is the seventh stage's point (FSAL).
            let next: [f64; 3] =
                std::array::from_fn(|d| u[d] + h * (0..6).map(|j| A[5][j] * k[j][d]).sum::<f64>());
            let err = (0..3)
                .map(|d| {
                    let e: f64 = (0..7).map(|j| E[j] * k[j][d]).sum::<f64>() * h;
                    e.abs() / (tol * width[d])
                })
                .fold(0.0, f64::max);
            if !err.is_finite() || err > 1.0 {
                h *= if err.is_finite() {
                    (0.9 * err.powf(-0.2)).max(0.2)
                } else {
                    0.2
                };
                continue;
            }
            // Outside the domain: shorten the step towards the face it crosses.
            let over = (0..3)
                .map(|d| (self.lo[d] - next[d]).max(next[d] - self.hi[d]) / width[d])
                .fold(f64::NEG_INFINITY, f64::max);
            if over > 0.0 {
                boundary_tries += 1;
                if over <= STREAMLINE_BOUNDARY_REL || boundary_tries > BOUNDARY_TRIES {
                    let clamped: [f64; 3] =
                        std::array::from_fn(|d| next[d].clamp(self.lo[d], self.hi[d]));
                    if let Ok((_, p)) = self.param_velocity(&clamped, &mut row) {
                        line.params.push(clamped);
                        line.points.push(p);
                        t += h;
                    }
                    line.end = StreamlineEnd::Boundary;
                    break;
                }
                let frac = (0..3)
                    .filter_map(|d| {
                        let to = if next[d] < self.lo[d] {
                            self.lo[d]
                        } else if next[d] > self.hi[d] {
                            self.hi[d]
                        } else {
                            return None;
                        };
                        Some((to - u[d]) / (next[d] - u[d]))
                    })
                    .fold(1.0, f64::min);
                if frac <= 0.0 {
                    // Already on the face and heading out.
                    line.end = StreamlineEnd::Boundary;
                    break;
                }
                h *= frac.min(1.0);
                continue;
            }
            boundary_tries = 0;
            t += h;
            u = next;
            k1 = k[6];
            line.params.push(u);
            line.points.push(end_point);
            steps += 1;
            h *= if err > 0.0 {
                (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
            } else {
                5.0
            };
        }
        line.time = t * sign;
        Ok(line)
    }
}

impl Volume {
    /// The volume with only the attributes `attrs` (indices, in that order; one may
    /// repeat, its copies then named `name#2` ..): the same knots and weights.
    pub fn with_attributes(&self, attrs: &[usize]) -> VolumeResult<Volume> {
        for &a in attrs {
            self.check_attribute(a)?;
        }
        if attrs.is_empty() {
            return Err(super::VolumeError::AttributeCount {
                got: 0,
                max: super::MAX_COMPONENTS,
            });
        }
        let mut names: Vec<String> = Vec::with_capacity(attrs.len());
        for &a in attrs {
            let base = &self.attributes()[a];
            let mut name = base.clone();
            let mut copy = 1;
            while names.contains(&name) {
                copy += 1;
                name = format!("{base}#{copy}");
            }
            names.push(name);
        }
        let dim = self.dim;
        let mut cw = Vec::with_capacity(self.point_count() * (attrs.len() + 1));
        for p in self.cw.chunks(dim) {
            cw.extend(attrs.iter().map(|&a| p[a]));
            cw.push(p[dim - 1]);
        }
        Ok(Volume::from_parts(self.knots.clone(), names, cw))
    }

    /// Checks an attribute index.
    pub(crate) fn check_attribute(&self, attr: usize) -> VolumeResult<()> {
        if attr < self.components() {
            Ok(())
        } else {
            Err(super::VolumeError::NoSuchAttribute {
                name: format!("#{attr}"),
                available: self.attributes().to_vec(),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tableau is consistent: each row of `a` sums to its node, and the error
    /// weights sum to zero (both weight sets sum to one).
    #[test]
    fn tableau_is_consistent() {
        for (s, row) in A.iter().enumerate() {
            crate::assert_near!(
                row.iter().sum::<f64>(),
                C[s + 1],
                crate::tolerance::EXACT_EPS
            );
        }
        crate::assert_near!(E.iter().sum::<f64>(), 0.0, crate::tolerance::EXACT_EPS);
    }
}
