//! The `wandsculpt-volume` JSON format (docs/formats/volume.md).
//!
//! ```json
//! {"format": "wandsculpt-volume", "version": 1,
//!  "degrees": [p1, .., pn],
//!  "knots": [[..], .., [..]],
//!  "attributes": ["x", "y", "z", "rho"],
//!  "control_points": [[[[x, y, z, rho], ..], ..], ..],
//!  "weights": [[[h, ..], ..], ..]}
//! ```
//!
//! `control_points` nests `n` levels deep, `control_points[i1][i2]..[in]` being the
//! point with index `i1` in the first direction (as the surface format's
//! `control_points[i][j]`); each leaf is a list of `k` numbers, one per attribute.
//! `weights` (optional, default 1) nests the same way with numbers as leaves. Knot
//! vectors are full and clamped. Unknown fields are rejected. The values are
//! Cartesian, not multiplied by the weights.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::{MAX_JSON_VALUE, NetIndex, Volume, VolumeError, VolumeResult, knot_vectors};

/// The value of the `format` field.
pub const FORMAT: &str = "wandsculpt-volume";
/// The format version this reader reads and the writer writes.
pub const VERSION: u64 = 1;

/// The serde form of [`Volume`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct VolumeJson {
    format: String,
    version: u64,
    degrees: Vec<usize>,
    knots: Vec<Vec<f64>>,
    attributes: Vec<String>,
    control_points: Value,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    weights: Option<Value>,
}

/// Walks a nested array `n = counts.len()` levels deep, checking every level's length,
/// and hands each leaf (with its index) to `leaf` in row-major order.
fn walk(
    what: &'static str,
    v: &Value,
    counts: &[usize],
    at: &mut Vec<usize>,
    leaf: &mut dyn FnMut(&Value, &[usize]) -> VolumeResult<()>,
) -> VolumeResult<()> {
    let level = at.len();
    if level == counts.len() {
        return leaf(v, at);
    }
    let list = v.as_array().ok_or_else(|| VolumeError::NestedShape {
        what,
        at: NetIndex(at.clone()),
        expected: "a list",
    })?;
    if list.len() != counts[level] {
        return Err(VolumeError::NestedLength {
            what,
            at: NetIndex(at.clone()),
            direction: level,
            got: list.len(),
            need: counts[level],
        });
    }
    for (i, item) in list.iter().enumerate() {
        at.push(i);
        walk(what, item, counts, at, leaf)?;
        at.pop();
    }
    Ok(())
}

fn number(what: &'static str, v: &Value, at: &[usize]) -> VolumeResult<f64> {
    v.as_f64().ok_or_else(|| VolumeError::NestedShape {
        what,
        at: NetIndex(at.to_vec()),
        expected: "a number",
    })
}

impl TryFrom<VolumeJson> for Volume {
    type Error = VolumeError;
    fn try_from(j: VolumeJson) -> VolumeResult<Self> {
        if j.format != FORMAT || j.version != VERSION {
            return Err(VolumeError::FormatTag {
                format: j.format,
                version: j.version,
            });
        }
        // Knots first: they fix the counts and cap the size before anything is built.
        let kvs = knot_vectors(&j.degrees, j.knots.clone())?;
        let counts: Vec<usize> = kvs.iter().map(|kv| kv.count()).collect();
        let k = j.attributes.len();
        let mut values = Vec::with_capacity(counts.iter().product::<usize>() * k);
        walk(
            "control_points",
            &j.control_points,
            &counts,
            &mut Vec::new(),
            &mut |v, at| {
                let list = v.as_array().ok_or_else(|| VolumeError::NestedShape {
                    what: "control_points",
                    at: NetIndex(at.to_vec()),
                    expected: "a list of numbers",
                })?;
                if list.len() != k {
                    return Err(VolumeError::LeafLength {
                        at: NetIndex(at.to_vec()),
                        got: list.len(),
                        need: k,
                    });
                }
                for x in list {
                    values.push(number("control_points", x, at)?);
                }
                Ok(())
            },
        )?;
        let weights = match &j.weights {
            None => None,
            Some(w) => {
                let mut out = Vec::with_capacity(values.len() / k.max(1));
                walk("weights", w, &counts, &mut Vec::new(), &mut |v, at| {
                    out.push(number("weights", v, at)?);
                    Ok(())
                })?;
                Some(out)
            }
        };
        Volume::new(j.degrees, j.knots, j.attributes, values, weights)
    }
}

/// Nests the flat row-major `leaves` `counts.len()` levels deep.
fn nest(counts: &[usize], leaves: &mut impl Iterator<Item = Value>) -> Value {
    match counts.split_first() {
        None => leaves.next().unwrap_or(Value::Null),
        Some((&c, rest)) => Value::Array((0..c).map(|_| nest(rest, leaves)).collect()),
    }
}

impl From<Volume> for VolumeJson {
    fn from(v: Volume) -> Self {
        let n_pts = v.point_count();
        // (h A) / h may round one ulp past the cap a value was read within: clamp it
        // back, so every written file reads again.
        let mut leaves = (0..n_pts).map(|i| {
            let values: Vec<f64> = v
                .control_values(i)
                .into_iter()
                .map(|x| x.clamp(-MAX_JSON_VALUE, MAX_JSON_VALUE))
                .collect();
            Value::from(values)
        });
        let control_points = nest(v.counts(), &mut leaves);
        let weights = v.is_rational().then(|| {
            let mut w = (0..n_pts).map(|i| Value::from(v.weight(i)));
            nest(v.counts(), &mut w)
        });
        VolumeJson {
            format: FORMAT.to_string(),
            version: VERSION,
            degrees: v.degrees(),
            knots: v
                .knot_vectors()
                .iter()
                .map(|kv| kv.knots().to_vec())
                .collect(),
            attributes: v.attributes().to_vec(),
            control_points,
            weights,
        }
    }
}

impl Volume {
    /// Reads the format of the module docs. Text that is not JSON or not the schema is
    /// [`VolumeError::Json`] (with its line and column); a volume the schema allows
    /// but that is invalid is the error naming the entry.
    pub fn from_json(text: &str) -> VolumeResult<Self> {
        let j: VolumeJson = serde_json::from_str(text).map_err(|e| VolumeError::Json(e.into()))?;
        Self::try_from(j)
    }

    /// Writes the format of the module docs (`weights` only when rational).
    pub fn to_json(&self) -> String {
        serde_json::to_string(&VolumeJson::from(self.clone())).unwrap_or_default()
    }
}
