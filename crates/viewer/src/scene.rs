//! What the page draws besides the recorded arrays, read tolerantly from a run's resolved
//! `scenario.toml`: each rod's name and per-element rest radius (linear taper, as the physics
//! builds it), the obstacles of every kind as written (`[[obstacle]]` spheres, `[[plane]]` and
//! `[[cylinder]]` tables, passed through with their kind for the page to draw), the targets and the grasped object. A missing or
//! unreadable scenario gives an empty scene: the page then draws rods with a default radius.

use serde_json::{json, Map, Value};

/// One rod of the scene.
fn rod_json(t: &toml::Table, default_name: String) -> Value {
    let num = |k: &str| {
        t.get(k)
            .and_then(|v| v.as_float().or(v.as_integer().map(|i| i as f64)))
    };
    let n = t
        .get("n_elements")
        .and_then(toml::Value::as_integer)
        .filter(|n| (1..=1_000_000).contains(n))
        .unwrap_or(0) as usize;
    let length = num("length").unwrap_or(f64::NAN);
    let base = num("base_diameter").unwrap_or(f64::NAN);
    let tip = num("tip_diameter").unwrap_or(base);
    let name = t
        .get("name")
        .and_then(toml::Value::as_str)
        .map(str::to_string)
        .unwrap_or(default_name);
    // Element j's rest radius at its centre s = (j + 1/2) L / n, as `StraightRod` builds it.
    let radius: Vec<f64> = if n > 0 && length > 0.0 && base.is_finite() && tip.is_finite() {
        (0..n)
            .map(|j| {
                let s = (j as f64 + 0.5) * length / n as f64;
                0.5 * (tip * s + base * (length - s)) / length
            })
            .collect()
    } else {
        Vec::new()
    };
    json!({
        "name": name,
        "n_elements": n,
        "length": if length.is_finite() { json!(length) } else { Value::Null },
        "radius": radius,
        "base_position": t.get("base_position").map(to_json),
        "base": t.get("base").map(to_json),
    })
}

/// A TOML value as JSON (dates as strings; non-finite floats as null).
fn to_json(v: &toml::Value) -> Value {
    match v {
        toml::Value::String(s) => json!(s),
        toml::Value::Integer(i) => json!(i),
        toml::Value::Float(f) if f.is_finite() => json!(f),
        toml::Value::Float(_) => Value::Null,
        toml::Value::Boolean(b) => json!(b),
        toml::Value::Datetime(d) => json!(d.to_string()),
        toml::Value::Array(a) => Value::Array(a.iter().map(to_json).collect()),
        toml::Value::Table(t) => {
            Value::Object(t.iter().map(|(k, v)| (k.clone(), to_json(v))).collect())
        }
    }
}

/// The scene of a scenario's text (empty fields where it cannot be read).
pub fn scene_of(scenario_toml: Option<&str>) -> Value {
    let table: toml::Table = scenario_toml
        .and_then(|t| t.parse::<toml::Table>().ok())
        .unwrap_or_default();
    let rods: Vec<Value> = match table.get("rod") {
        Some(toml::Value::Table(t)) => vec![rod_json(t, "rod".into())],
        Some(toml::Value::Array(list)) => list
            .iter()
            .enumerate()
            .filter_map(|(i, v)| v.as_table().map(|t| rod_json(t, format!("rod{i}"))))
            .collect(),
        _ => Vec::new(),
    };
    let list = |key: &str| -> Vec<Value> {
        table
            .get(key)
            .and_then(toml::Value::as_array)
            .map(|a| a.iter().map(to_json).collect())
            .unwrap_or_default()
    };
    // `[[obstacle]]` (spheres unless a kind says otherwise), `[[plane]]` and `[[cylinder]]`.
    let obstacles: Vec<Value> = [
        ("obstacle", "sphere"),
        ("plane", "plane"),
        ("cylinder", "cylinder"),
    ]
    .into_iter()
    .flat_map(|(key, kind)| {
        list(key).into_iter().map(move |mut o| {
            if let Some(m) = o.as_object_mut() {
                m.entry("kind").or_insert(json!(kind));
            }
            o
        })
    })
    .collect();
    let mut out = Map::new();
    out.insert("rods".into(), Value::Array(rods));
    out.insert("obstacles".into(), Value::Array(obstacles));
    out.insert("targets".into(), Value::Array(list("target")));
    out.insert(
        "grasp".into(),
        table.get("grasp").map(to_json).unwrap_or(Value::Null),
    );
    out.insert(
        "controller".into(),
        table.get("controller").map(to_json).unwrap_or(Value::Null),
    );
    out.insert(
        "description".into(),
        table.get("description").map(to_json).unwrap_or(Value::Null),
    );
    out.insert(
        "duration".into(),
        table
            .get("time")
            .and_then(|t| t.get("duration"))
            .map(to_json)
            .unwrap_or(Value::Null),
    );
    Value::Object(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rods_taper_and_obstacles_pass_through() {
        let text =
            "[rod]\nn_elements = 4\nlength = 0.2\nbase_diameter = 0.02\ntip_diameter = 0.004\n\
                    [[obstacle]]\ncenter = [0.1, 0.0, 0.0]\ndiameter = 0.04\n\
                    [[obstacle]]\nkind = \"plane\"\nnormal = [0.0, 0.0, 1.0]\n";
        let s = scene_of(Some(text));
        let r = &s["rods"][0]["radius"];
        assert_eq!(s["rods"][0]["name"], "rod");
        // Element centres at 0.025, 0.075, ...: r = (0.02 (L - s) + 0.004 s) / (2 L).
        assert!((r[0].as_f64().unwrap() - 0.5 * (0.02 - 0.016 * 0.125)).abs() < 1e-12);
        assert!(r[3].as_f64().unwrap() < r[0].as_f64().unwrap());
        assert_eq!(s["obstacles"][0]["kind"], "sphere");
        assert_eq!(s["obstacles"][1]["kind"], "plane");
    }

    #[test]
    fn unreadable_scenarios_give_an_empty_scene() {
        let s = scene_of(Some("this is = = not toml"));
        assert_eq!(s["rods"].as_array().unwrap().len(), 0);
        let s = scene_of(None);
        assert_eq!(s["obstacles"].as_array().unwrap().len(), 0);
    }
}
