//! `--check EXPECTED.json`: compare a replay's outcome against expectations, with a
//! readable diff.
//!
//! The expectations are a JSON object shaped like the outcome (`metrics.json`), listing
//! only the keys to check. Each expected leaf is one of:
//! - a plain value (number, string, bool, null): must be equal (numbers exactly);
//! - `{"min": a, "max": b}` (either bound may be left out): a number in range;
//! - `{"approx": x, "tol": t}`: a number within `t` of `x`;
//! - an array: the same length, compared element by element;
//! - an object: compared key by key (keys missing from the outcome are reported).
//!
//! ```
//! use serde_json::json;
//! let actual = json!({"strokes": 3, "tracking": {"losses": 1}, "frames": 1200});
//! let expected = json!({"strokes": 3, "tracking": {"losses": {"min": 0, "max": 2}}, "frames": {"approx": 1190, "tol": 20}});
//! assert!(replay::check::check(&expected, &actual).is_empty());
//! let bad = json!({"strokes": 4});
//! assert_eq!(replay::check::check(&bad, &actual), vec!["strokes: expected 4, got 3".to_string()]);
//! ```

use serde_json::Value;

/// Compares `actual` against `expected` and returns one line per mismatch (empty when
/// everything matches), each naming the JSON path.
pub fn check(expected: &Value, actual: &Value) -> Vec<String> {
    let mut out = Vec::new();
    walk("", expected, actual, &mut out);
    out
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

fn is_range(obj: &serde_json::Map<String, Value>) -> bool {
    !obj.is_empty() && obj.keys().all(|k| k == "min" || k == "max")
}

fn is_approx(obj: &serde_json::Map<String, Value>) -> bool {
    obj.contains_key("approx") && obj.keys().all(|k| k == "approx" || k == "tol")
}

fn walk(path: &str, expected: &Value, actual: &Value, out: &mut Vec<String>) {
    let at = if path.is_empty() { "(root)" } else { path };
    match expected {
        Value::Object(obj) if is_range(obj) => {
            let Some(x) = actual.as_f64() else {
                out.push(format!("{at}: expected a number in range, got {actual}"));
                return;
            };
            let lo = obj.get("min").and_then(Value::as_f64);
            let hi = obj.get("max").and_then(Value::as_f64);
            let ok = lo.is_none_or(|lo| x >= lo) && hi.is_none_or(|hi| x <= hi);
            if !ok {
                let show = |b: Option<f64>| b.map_or("..".to_string(), |v| v.to_string());
                out.push(format!(
                    "{at}: expected {} ..= {}, got {actual}",
                    show(lo),
                    show(hi)
                ));
            }
        }
        Value::Object(obj) if is_approx(obj) => {
            let want = obj.get("approx").and_then(Value::as_f64);
            let tol = obj.get("tol").and_then(Value::as_f64).unwrap_or(0.0);
            match (want, actual.as_f64()) {
                (Some(w), Some(x)) if (x - w).abs() <= tol => {}
                (Some(w), _) => out.push(format!("{at}: expected {w} ± {tol}, got {actual}")),
                (None, _) => out.push(format!("{at}: \"approx\" must be a number")),
            }
        }
        Value::Object(obj) => {
            let Some(act) = actual.as_object() else {
                out.push(format!("{at}: expected an object, got {actual}"));
                return;
            };
            for (k, v) in obj {
                match act.get(k) {
                    Some(a) => walk(&join(path, k), v, a, out),
                    None => out.push(format!("{}: missing from the outcome", join(path, k))),
                }
            }
        }
        Value::Array(items) => {
            let Some(act) = actual.as_array() else {
                out.push(format!("{at}: expected an array, got {actual}"));
                return;
            };
            if items.len() != act.len() {
                out.push(format!(
                    "{at}: expected {} items, got {}",
                    items.len(),
                    act.len()
                ));
            }
            for (i, (e, a)) in items.iter().zip(act).enumerate() {
                walk(&format!("{path}[{i}]"), e, a, out);
            }
        }
        leaf => {
            let equal = match (leaf.as_f64(), actual.as_f64()) {
                (Some(a), Some(b)) => a == b,
                _ => leaf == actual,
            };
            if !equal {
                out.push(format!("{at}: expected {leaf}, got {actual}"));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn reports_every_mismatch_with_its_path() {
        let actual = json!({
            "strokes": 2,
            "per_stroke": [{"samples": 10}, {"samples": 3}],
            "mode": "carve",
        });
        let expected = json!({
            "strokes": {"min": 3},
            "per_stroke": [{"samples": {"min": 5}}, {"samples": {"min": 5}}],
            "mode": "emboss",
            "targets": 1,
        });
        let mut diff = check(&expected, &actual);
        diff.sort();
        assert_eq!(
            diff,
            vec![
                "mode: expected \"emboss\", got \"carve\"",
                "per_stroke[1].samples: expected 5 ..= .., got 3",
                "strokes: expected 3 ..= .., got 2",
                "targets: missing from the outcome",
            ]
        );
    }

    #[test]
    fn type_mismatches_are_reported_not_panicked() {
        let diff = check(
            &json!({"a": {"min": 1}, "b": [1], "c": {"x": 1}}),
            &json!({"a": "x", "b": 2, "c": 3}),
        );
        assert_eq!(diff.len(), 3);
        assert!(
            check(
                &json!({"n": {"approx": 1.0, "tol": 0.1}}),
                &json!({"n": 1.05})
            )
            .is_empty()
        );
        assert_eq!(check(&json!([1, 2]), &json!([1])).len(), 1);
    }
}
