//! Uniform parameter grids (Park 2005, sec. 5.1, grid generation): the parameters
//! `a_d + (b_d - a_d) i / (r_d - 1)`, `i = 0..r_d`, over each direction's knot domain
//! `[a_d, b_d]`, and the attribute values there with the first index fastest (the
//! order of VTK's points, `sculpt-tools volume grid`, and the GPU path
//! `wandsculpt --gpu-volume-eval`).

use super::{Volume, VolumeError, VolumeResult};

impl Volume {
    /// The uniform grid parameters of every direction for `res[d]` points in direction
    /// `d` (a direction with one point takes its domain's start).
    pub fn grid_params(&self, res: &[usize]) -> VolumeResult<Vec<Vec<f64>>> {
        if res.len() != self.directions() {
            return Err(VolumeError::ParamCount {
                got: res.len(),
                need: self.directions(),
            });
        }
        Ok(self
            .domain()
            .into_iter()
            .zip(res)
            .map(|((a, b), &r)| {
                (0..r)
                    .map(|i| {
                        if r > 1 {
                            a + (b - a) * i as f64 / (r - 1) as f64
                        } else {
                            a
                        }
                    })
                    .collect()
            })
            .collect())
    }

    /// The `k` attribute values at every point of the uniform grid of `res` (see
    /// [`Self::grid_params`]), the first index fastest, into `out`: `k` values per
    /// point, `prod res` points. `f` receives each point's values (in f64) and writes
    /// them where it likes; this is the CPU reference of the GPU path.
    pub fn eval_grid(&self, res: &[usize], mut f: impl FnMut(usize, &[f64])) -> VolumeResult<()> {
        let params = self.grid_params(res)?;
        let n = self.directions();
        let total: usize = res.iter().product();
        let mut value = vec![0.0; self.components()];
        let mut u = vec![0.0; n];
        for flat in 0..total {
            let mut rest = flat;
            for d in 0..n {
                u[d] = params[d][rest % res[d]];
                rest /= res[d];
            }
            self.eval_into(&u, &mut value)?;
            f(flat, &value);
        }
        Ok(())
    }

    /// [`Self::eval_grid`] rounded to f32: `k` values per point, the first index
    /// fastest (the layout of `sculpt-tools volume grid --f32` and of
    /// `wandsculpt --gpu-volume-eval`).
    pub fn eval_grid_f32(&self, res: &[usize]) -> VolumeResult<Vec<f32>> {
        let total: usize = res.iter().product();
        let mut out = Vec::with_capacity(total * self.components());
        self.eval_grid(res, |_, v| out.extend(v.iter().map(|&x| x as f32)))?;
        Ok(out)
    }
}
