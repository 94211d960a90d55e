//! A sweep's plan: the sweep file parsed and checked (errors with file:line:col, key and allowed
//! values, like scenarios), each parameter's values (lists, linear/log ranges, seeded random
//! samples), their combination (zipped within a group, groups crossed), and every run's scenario
//! resolved and validated through the normal scenario path, with its content-hash id. It runs
//! nothing and writes nothing.

use crate::scenario::toml_errors::{explain_toml_error, split_unknown};
use crate::scenario::{fmt_num, key_span, line_col, nearest, Scenario, ScenarioError};
use crate::scenario::{ScenarioConfig, MAX_SCENARIO_BYTES};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::path::{Path, PathBuf};
use toml::Value;

/// Largest accepted number of runs in one sweep (the product of the groups' lengths).
pub const MAX_SWEEP_RUNS: usize = 100_000;
/// Largest accepted number of `[[parameter]]` tables in a sweep file.
pub const MAX_SWEEP_PARAMETERS: usize = 64;
/// Largest accepted number of values of one parameter (`values`, `range.num`, `random.count`).
pub const MAX_SWEEP_VALUES: usize = 100_000;
/// Characters of a run id (hexadecimal digits of the content hash).
pub const RUN_ID_LEN: usize = 12;

/// How the parameters' values combine: crossed (every combination, the default) or zipped
/// (the i-th values together; all parameters have the same number of values).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Combine {
    /// Every combination of the groups' values (a grid).
    #[default]
    Cross,
    /// All parameters zipped into one group.
    Zip,
}

/// Spacing of a range or the distribution of random samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scale {
    /// Evenly spaced (uniform) values.
    #[default]
    Linear,
    /// Evenly spaced (uniform) logarithms; every value must be positive.
    Log,
}

/// The sweep file, as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepFile {
    scenario: String,
    #[serde(default)]
    description: Option<String>,
    #[serde(default)]
    seed: u64,
    #[serde(default)]
    combine: Combine,
    #[serde(default, rename = "parameter")]
    parameters: Vec<ParameterFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParameterFile {
    path: String,
    #[serde(default)]
    values: Option<Vec<Value>>,
    #[serde(default)]
    range: Option<RangeFile>,
    #[serde(default)]
    random: Option<RandomFile>,
    #[serde(default)]
    group: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RangeFile {
    start: Value,
    stop: Value,
    num: usize,
    #[serde(default)]
    scale: Scale,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RandomFile {
    low: Value,
    high: Value,
    count: usize,
    #[serde(default)]
    scale: Scale,
}

/// One swept parameter with its values.
#[derive(Debug, Clone)]
pub struct Parameter {
    /// The scenario key path, e.g. `rod.youngs_modulus` or `target[0].position`.
    pub path: String,
    /// How the values were given: `values`, `range` or `random`, and the scale.
    pub how: serde_json::Value,
    /// The values, in order (TOML values, as written into the scenario).
    pub values: Vec<Value>,
    /// The group it is zipped in (its own path when not grouped).
    pub group: String,
    /// Its columns in the results table: the path, or `path[k]` per component of a vector.
    pub columns: Vec<String>,
}

/// Whether a planned run's scenario is valid.
#[derive(Debug, Clone, PartialEq)]
pub enum RunCheck {
    /// It passed every check of `octoarm check`'s scenario loader.
    Valid,
    /// It failed them: the message (key, value, allowed range), without a file location.
    Invalid(String),
}

/// One run of the plan (its scenario text is rebuilt on demand by `SweepPlan::scenario_text`).
#[derive(Debug, Clone)]
pub struct PlannedRun {
    /// Position in the plan, 0-based.
    pub index: usize,
    /// Content hash of the resolved scenario (`RUN_ID_LEN` hex digits): the folder name
    /// `runs/<id>/`, the same on every machine and version.
    pub id: String,
    /// Index of each parameter's value.
    pub choice: Vec<usize>,
    /// Valid, or why not.
    pub check: RunCheck,
}

/// A sweep file resolved against its base scenario: parameters, runs and their ids.
#[derive(Debug, Clone)]
pub struct SweepPlan {
    /// The sweep file.
    pub path: PathBuf,
    /// Its description, if any.
    pub description: Option<String>,
    /// Seed of the random samples.
    pub seed: u64,
    /// How the parameters combine.
    pub combine: Combine,
    /// The base scenario (with `--duration` applied, if given).
    pub base: Scenario,
    /// The parameters, in file order.
    pub parameters: Vec<Parameter>,
    /// The runs, in plan order (the first group varies slowest).
    pub runs: Vec<PlannedRun>,
    base_value: Value,
}

fn err_at(path: &Path, source: &str, key: &str, message: String) -> ScenarioError {
    ScenarioError {
        file: path.to_path_buf(),
        line: key_span(source, key).map(|s| line_col(source, s.start)),
        message,
    }
}

/// Read a text file of at most `MAX_SCENARIO_BYTES`.
fn read_limited(path: &Path, what: &str) -> Result<String, ScenarioError> {
    use std::io::Read;
    let fail = |message: String| ScenarioError {
        file: path.to_path_buf(),
        line: None,
        message,
    };
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_SCENARIO_BYTES + 1).read_to_end(&mut bytes))
        .map_err(|e| fail(format!("cannot read the {what}: {e}")))?;
    if bytes.len() as u64 > MAX_SCENARIO_BYTES {
        return Err(fail(format!(
            "the {what} is larger than {} MiB, the limit",
            MAX_SCENARIO_BYTES >> 20
        )));
    }
    String::from_utf8(bytes).map_err(|_| fail(format!("the {what} is not UTF-8 text")))
}

impl SweepPlan {
    /// Read a sweep file, load its base scenario (`scenario = "..."`, relative to the sweep
    /// file), apply `duration` to it if given, build every parameter's values and every run,
    /// and check each run's scenario. Errors in the sweep file (syntax, unknown keys, unknown
    /// parameter paths, empty or ill-formed ranges, values of the wrong type, too many runs)
    /// name the sweep file's line and key; errors in the base scenario name the scenario's.
    /// Runs whose combination of values is invalid are kept, marked `RunCheck::Invalid`; if
    /// every run is invalid the first one's error is returned.
    pub fn load(path: &Path, duration: Option<f64>) -> Result<Self, ScenarioError> {
        let source = read_limited(path, "sweep file")?;
        Self::from_str(path, &source, duration)
    }

    /// `load` from the sweep file's text; `path` names it and anchors the base scenario's path.
    pub fn from_str(
        path: &Path,
        source: &str,
        duration: Option<f64>,
    ) -> Result<Self, ScenarioError> {
        let at = |key: &str, message: String| err_at(path, source, key, message);
        let file: SweepFile = toml::from_str(source).map_err(|e| ScenarioError {
            file: path.to_path_buf(),
            line: e.span().map(|s| line_col(source, s.start)),
            message: sweep_toml_error(source, &e),
        })?;
        if file.parameters.is_empty() {
            return Err(at(
                "",
                "no [[parameter]] table: a sweep needs at least one parameter \
                 ([[parameter]] with path = \"...\" and values, range or random)"
                    .into(),
            ));
        }
        if file.parameters.len() > MAX_SWEEP_PARAMETERS {
            return Err(at(
                "parameter",
                format!(
                    "parameter = {} [[parameter]] tables is outside the allowed range of at most \
                     {MAX_SWEEP_PARAMETERS}",
                    file.parameters.len()
                ),
            ));
        }
        let base_path = match path.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir.join(&file.scenario),
            _ => PathBuf::from(&file.scenario),
        };
        if !base_path.is_file() {
            return Err(at(
                "scenario",
                format!(
                    "scenario = {:?}: no such file {} (the path is relative to the sweep file's \
                     folder)",
                    file.scenario,
                    base_path.display()
                ),
            ));
        }
        let mut base = Scenario::load(&base_path)?;
        if let Some(d) = duration {
            crate::override_duration(&mut base, d)?;
        }
        let base_value: Value =
            toml::from_str(&base.resolved_toml()).expect("a resolved scenario parses");

        let mut parameters = Vec::with_capacity(file.parameters.len());
        for (i, p) in file.parameters.iter().enumerate() {
            let key = format!("parameter[{i}]");
            if let Some(j) = file.parameters[..i].iter().position(|q| q.path == p.path) {
                return Err(at(
                    &format!("{key}.path"),
                    format!(
                        "{key}.path = {:?} is swept twice (also parameter[{j}]); zip or merge \
                         the two",
                        p.path
                    ),
                ));
            }
            if file.combine == Combine::Zip && p.group.is_some() {
                return Err(at(
                    &format!("{key}.group"),
                    format!(
                        "{key}.group: groups are only used with combine = \"cross\" (with \
                         combine = \"zip\" every parameter is zipped)"
                    ),
                ));
            }
            let segments = parse_path(&p.path).map_err(|m| at(&format!("{key}.path"), m))?;
            let current = get_path(&base_value, &segments)
                .map_err(|m| at(&format!("{key}.path"), format!("{key}.path: {m}")))?;
            let integer = matches!(current, Some(Value::Integer(_)));
            let (values, how) =
                values_of(p, &key, integer, file.seed, i).map_err(|(k, m)| at(&k, m))?;
            let columns = columns_of(&p.path, &values).map_err(|m| at(&key, m))?;
            // Each value alone on the base scenario must have the key's type.
            for (k, v) in values.iter().enumerate() {
                let mut doc = base_value.clone();
                set_path(&mut doc, &segments, v.clone())
                    .map_err(|m| at(&format!("{key}.path"), format!("{key}.path: {m}")))?;
                if let Err(e) = ScenarioConfig::deserialize(doc) {
                    let why = type_error(&p.path, &e);
                    let field = if why.starts_with("unknown parameter path") {
                        format!("{key}.path")
                    } else {
                        format!("{key}.{}", value_field(p))
                    };
                    return Err(at(
                        &field,
                        format!(
                            "{key} ({}): value {} of {} = {}: {}",
                            p.path,
                            k + 1,
                            values.len(),
                            inline(v),
                            why
                        ),
                    ));
                }
            }
            let group = match file.combine {
                Combine::Zip => "all".to_string(),
                Combine::Cross => p.group.clone().unwrap_or_else(|| p.path.clone()),
            };
            parameters.push(Parameter {
                path: p.path.clone(),
                how,
                values,
                group,
                columns,
            });
        }

        // Groups in order of first appearance; zipped parameters have equal lengths.
        let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
        for (i, p) in parameters.iter().enumerate() {
            match groups.iter_mut().find(|(g, _)| *g == p.group) {
                Some((_, members)) => {
                    let first = &parameters[members[0]];
                    if first.values.len() != p.values.len() {
                        return Err(at(
                            &format!("parameter[{i}]"),
                            format!(
                                "parameter[{i}] ({}) has {} values but is zipped with parameter[{}] \
                                 ({}), which has {}: zipped parameters need the same number of values",
                                p.path,
                                p.values.len(),
                                members[0],
                                first.path,
                                first.values.len()
                            ),
                        ));
                    }
                    members.push(i);
                }
                None => groups.push((p.group.clone(), vec![i])),
            }
        }
        let lengths: Vec<usize> = groups
            .iter()
            .map(|(_, m)| parameters[m[0]].values.len())
            .collect();
        let total = lengths
            .iter()
            .try_fold(1usize, |acc, &n| acc.checked_mul(n))
            .filter(|&n| n <= MAX_SWEEP_RUNS)
            .ok_or_else(|| {
                let shown: Vec<String> = lengths.iter().map(|n| n.to_string()).collect();
                at(
                    "parameter",
                    format!(
                        "the sweep has {} runs, outside the allowed range of at most \
                         {MAX_SWEEP_RUNS} runs; use fewer values or zip parameters (group = \"...\")",
                        if shown.len() > 1 {
                            format!(
                                "{} = {}",
                                shown.join(" x "),
                                lengths
                                    .iter()
                                    .map(|&n| n as f64)
                                    .product::<f64>()
                            )
                        } else {
                            shown.join("")
                        }
                    ),
                )
            })?;

        let mut plan = Self {
            path: path.to_path_buf(),
            description: file.description,
            seed: file.seed,
            combine: file.combine,
            base,
            parameters,
            runs: Vec::with_capacity(total),
            base_value,
        };
        let segments: Vec<Vec<Segment>> = plan
            .parameters
            .iter()
            .map(|p| parse_path(&p.path).expect("checked above"))
            .collect();
        let mut seen: std::collections::HashMap<String, usize> = Default::default();
        for index in 0..total {
            let mut choice = vec![0; plan.parameters.len()];
            let mut rest = index;
            for ((_, members), &n) in groups.iter().zip(&lengths).rev() {
                for &m in members {
                    choice[m] = rest % n;
                }
                rest /= n;
            }
            let (text, check) = plan.build(&segments, &choice);
            let id = run_id(&text);
            if let Some(&other) = seen.get(&id) {
                return Err(at(
                    "parameter",
                    format!(
                        "runs {other} and {index} have the same scenario (id {id}): {} and {}; \
                         remove the duplicate values",
                        plan.describe_choice(&plan.runs[other].choice),
                        plan.describe_choice(&choice)
                    ),
                ));
            }
            seen.insert(id.clone(), index);
            plan.runs.push(PlannedRun {
                index,
                id,
                choice,
                check,
            });
        }
        if let Some(RunCheck::Invalid(first)) = plan
            .runs
            .iter()
            .all(|r| r.check != RunCheck::Valid)
            .then(|| plan.runs[0].check.clone())
        {
            return Err(at(
                "parameter",
                format!(
                    "no run of the sweep is a valid scenario; the first ({}): {first}",
                    plan.describe_choice(&plan.runs[0].choice)
                ),
            ));
        }
        Ok(plan)
    }

    /// The run's scenario text (resolved, with octoarm's header) and whether it is valid.
    fn build(&self, segments: &[Vec<Segment>], choice: &[usize]) -> (String, RunCheck) {
        let mut doc = self.base_value.clone();
        for ((p, seg), &k) in self.parameters.iter().zip(segments).zip(choice) {
            set_path(&mut doc, seg, p.values[k].clone()).expect("checked in load");
        }
        let text = toml::to_string(&doc).expect("a TOML table serialises");
        match Scenario::from_str(&self.base.path, &text) {
            Ok(scn) => (scn.resolved_toml(), RunCheck::Valid),
            // The location would be in the generated text: the message names the key.
            Err(e) => (text, RunCheck::Invalid(e.message)),
        }
    }

    /// The scenario text of run `index`: what `runs/<id>/scenario.toml` holds (for an invalid
    /// run, the unresolved text that failed).
    pub fn scenario_text(&self, index: usize) -> String {
        let segments: Vec<Vec<Segment>> = self
            .parameters
            .iter()
            .map(|p| parse_path(&p.path).expect("checked in load"))
            .collect();
        self.build(&segments, &self.runs[index].choice).0
    }

    /// The scenario of a valid run, loaded from its text exactly as a Ray worker loads it
    /// (`octoarm.run_scenario(path, source=text)`): named after the base scenario's file.
    pub fn scenario(&self, index: usize) -> Result<Scenario, ScenarioError> {
        Scenario::from_str(&self.base.path, &self.scenario_text(index))
    }

    /// `path = value, ...` of a run's choice, for messages.
    pub fn describe_choice(&self, choice: &[usize]) -> String {
        self.parameters
            .iter()
            .zip(choice)
            .map(|(p, &k)| format!("{} = {}", p.path, inline(&p.values[k])))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The cells of a run's parameter columns (numbers as the shortest text that reads back
    /// exactly; other values as TOML).
    pub fn parameter_cells(&self, index: usize) -> Vec<Cell> {
        let mut out = Vec::new();
        for (p, &k) in self.parameters.iter().zip(&self.runs[index].choice) {
            let v = &p.values[k];
            match v {
                Value::Array(a) if p.columns.len() == a.len() && p.columns.len() > 1 => {
                    out.extend(a.iter().map(cell_of));
                }
                _ => out.push(cell_of(v)),
            }
        }
        out
    }

    /// The resolved plan as JSON (for `sweep.json`): parameters with their values and how they
    /// combine, and every run's id, values and check.
    pub fn to_json(&self) -> serde_json::Value {
        let parameters: Vec<serde_json::Value> = self
            .parameters
            .iter()
            .map(|p| {
                json!({
                    "path": p.path,
                    "how": p.how,
                    "group": p.group,
                    "columns": p.columns,
                    "values": serde_json::to_value(&p.values).unwrap_or_default(),
                })
            })
            .collect();
        let runs: Vec<serde_json::Value> = self
            .runs
            .iter()
            .map(|r| {
                let values: serde_json::Map<String, serde_json::Value> = self
                    .parameters
                    .iter()
                    .zip(&r.choice)
                    .map(|(p, &k)| {
                        (
                            p.path.clone(),
                            serde_json::to_value(&p.values[k]).unwrap_or_default(),
                        )
                    })
                    .collect();
                let mut o = json!({"index": r.index, "id": r.id, "values": values});
                if let RunCheck::Invalid(m) = &r.check {
                    o["invalid"] = json!(m);
                }
                o
            })
            .collect();
        json!({
            "sweep_file": self.path.display().to_string(),
            "scenario": self.base.path.display().to_string(),
            "description": self.description,
            "seed": self.seed,
            "combine": self.combine,
            "parameters": parameters,
            "runs": runs,
        })
    }
}

/// A cell of the results table.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// A number (NaN: missing).
    Num(f64),
    /// Text.
    Text(String),
}

fn cell_of(v: &Value) -> Cell {
    match v {
        Value::Integer(i) => Cell::Num(*i as f64),
        Value::Float(f) => Cell::Num(*f),
        Value::String(s) => Cell::Text(s.clone()),
        other => Cell::Text(inline(other)),
    }
}

/// A TOML value on one line.
pub fn inline(v: &Value) -> String {
    match v {
        Value::Float(f) => fmt_num(*f),
        Value::Array(a) => format!("[{}]", a.iter().map(inline).collect::<Vec<_>>().join(", ")),
        other => other.to_string(),
    }
}

/// The sweep file key holding a parameter's values, for error locations.
fn value_field(p: &ParameterFile) -> &'static str {
    if p.values.is_some() {
        "values"
    } else if p.range.is_some() {
        "range"
    } else {
        "random"
    }
}

/// A serde error of the whole scenario, as one line about the swept key.
fn type_error(path: &str, e: &toml::de::Error) -> String {
    let msg = e.message().trim().replace('\n', ": ");
    if let Some(rest) = msg.strip_prefix("unknown field `") {
        let (name, expected) = split_unknown(rest);
        let hint = nearest(&name, &expected)
            .map(|n| format!("; did you mean `{n}`?"))
            .unwrap_or_default();
        return format!(
            "unknown parameter path `{path}`: no key `{name}` there{hint} (allowed: {})",
            expected.join(", ")
        );
    }
    if let Some(rest) = msg.strip_prefix("unknown variant `") {
        let (name, expected) = split_unknown(rest);
        let hint = nearest(&name, &expected)
            .map(|n| format!("; did you mean \"{n}\"?"))
            .unwrap_or_default();
        return format!(
            "unknown kind \"{name}\"{hint} (allowed: {})",
            expected.join(", ")
        );
    }
    if msg.contains("expected usize") || msg.contains("expected u64") {
        return format!("{path} expects a whole number ({msg})");
    }
    format!("not a valid value of {path}: {msg}")
}

/// A toml error of the sweep file, explained like a scenario's (nearest names for typos).
fn sweep_toml_error(source: &str, e: &toml::de::Error) -> String {
    let msg = e.message();
    if msg.contains("invalid type: map, expected a sequence") {
        return "[parameter] must be written [[parameter]]: one [[parameter]] table per swept \
                parameter"
            .into();
    }
    explain_toml_error(source, e)
}

/// One step of a key path: a name and an optional index.
#[derive(Debug, Clone, PartialEq)]
struct Segment {
    name: String,
    index: Option<usize>,
}

fn parse_path(path: &str) -> Result<Vec<Segment>, String> {
    let bad = |why: &str| {
        format!(
            "path = {path:?} is not a scenario key path ({why}); write it as in the scenario, \
             e.g. \"rod.youngs_modulus\", \"rod[1].length\", \"target[0].position\" or \
             \"target[0].position[1]\""
        )
    };
    if path.is_empty() {
        return Err(bad("empty"));
    }
    path.split('.')
        .map(|part| {
            let (name, index) = match part.split_once('[') {
                Some((n, rest)) => {
                    let i = rest
                        .strip_suffix(']')
                        .and_then(|d| d.parse::<usize>().ok())
                        .ok_or_else(|| bad(&format!("`{part}` has a bad index")))?;
                    (n, Some(i))
                }
                None => (part, None),
            };
            let ok = !name.is_empty()
                && name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
            if !ok {
                return Err(bad(&format!("`{part}` is not a key")));
            }
            Ok(Segment {
                name: name.to_string(),
                index,
            })
        })
        .collect()
}

fn keys_of(t: &toml::Table) -> Vec<String> {
    t.keys().cloned().collect()
}

fn unknown(prefix: &str, name: &str, t: &toml::Table) -> String {
    let keys = keys_of(t);
    let hint = nearest(name, &keys)
        .map(|n| format!("; did you mean `{n}`?"))
        .unwrap_or_default();
    let at = if prefix.is_empty() {
        "the scenario's top level".to_string()
    } else {
        format!("`{prefix}`")
    };
    format!(
        "unknown parameter path: {at} has no key `{name}` in the (resolved) base scenario{hint} \
         (keys there: {})",
        keys.join(", ")
    )
}

/// Step into `item` by `seg.index`, if any.
fn index_into<'a>(
    item: &'a mut Value,
    seg: &Segment,
    shown: &str,
) -> Result<&'a mut Value, String> {
    match (item, seg.index) {
        (item, None) => Ok(item),
        (Value::Array(a), Some(i)) => {
            let n = a.len();
            a.get_mut(i).ok_or_else(|| {
                format!(
                    "`{shown}`: index {i} is outside the allowed range [0, {}] ({n} entries in the \
                     base scenario)",
                    n.saturating_sub(1)
                )
            })
        }
        (item @ Value::Table(_), Some(0)) => Ok(item),
        (_, Some(_)) => Err(format!(
            "`{shown}`: `{}` is not an array in the base scenario; remove the index",
            seg.name
        )),
    }
}

/// Set `value` at `segments` in the scenario document. Every step but the last must exist; the
/// last key may be new (an optional key), which the scenario's deserialisation then checks.
fn set_path(doc: &mut Value, segments: &[Segment], value: Value) -> Result<(), String> {
    let mut cur = doc;
    let mut shown = String::new();
    for (n, seg) in segments.iter().enumerate() {
        let last = n + 1 == segments.len();
        let prefix = shown.clone();
        if !shown.is_empty() {
            shown.push('.');
        }
        shown.push_str(&seg.name);
        if let Some(i) = seg.index {
            shown.push_str(&format!("[{i}]"));
        }
        let Value::Table(t) = cur else {
            return Err(format!("`{prefix}` is a value, not a table"));
        };
        if last && seg.index.is_none() {
            t.insert(seg.name.clone(), value);
            return Ok(());
        }
        if !t.contains_key(&seg.name) {
            return Err(unknown(&prefix, &seg.name, t));
        }
        let item = t.get_mut(&seg.name).expect("checked");
        if last {
            let slot = index_into(item, seg, &shown)?;
            *slot = value;
            return Ok(());
        }
        if matches!(item, Value::Array(_)) && seg.index.is_none() {
            return Err(format!(
                "`{shown}` is an array of tables: name one, e.g. `{shown}[0]`"
            ));
        }
        cur = index_into(item, seg, &shown)?;
    }
    Ok(())
}

/// The base scenario's value at `segments` (None: an absent last key); errors as `set_path`.
fn get_path<'a>(doc: &'a Value, segments: &[Segment]) -> Result<Option<&'a Value>, String> {
    let mut probe = doc.clone();
    set_path(&mut probe, segments, Value::Boolean(false))?;
    let mut cur = Some(doc);
    for seg in segments {
        cur = cur
            .and_then(|v| v.get(&seg.name))
            .and_then(|v| match (v, seg.index) {
                (Value::Array(a), Some(i)) => a.get(i),
                (v, _) => Some(v),
            });
    }
    Ok(cur)
}

/// Numbers of a scalar or a vector value: (is_vector, components).
fn point(v: &Value) -> Option<(bool, Vec<f64>)> {
    let num = |v: &Value| match v {
        Value::Integer(i) => Some(*i as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    };
    match v {
        Value::Array(a) if !a.is_empty() => {
            Some((true, a.iter().map(num).collect::<Option<Vec<f64>>>()?))
        }
        v => num(v).map(|x| (false, vec![x])),
    }
}

fn make_value(vector: bool, xs: &[f64], integer: bool) -> Value {
    let one = |x: f64| {
        if integer {
            Value::Integer(x as i64)
        } else {
            Value::Float(x)
        }
    };
    if vector {
        Value::Array(xs.iter().map(|&x| one(x)).collect())
    } else {
        one(xs[0])
    }
}

/// SplitMix64: a tiny generator whose output is fixed forever (the plan must not change with a
/// library version).
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

type KeyedError = (String, String);

/// The values of parameter `i` and a description of how they were given.
fn values_of(
    p: &ParameterFile,
    key: &str,
    integer: bool,
    seed: u64,
    i: usize,
) -> Result<(Vec<Value>, serde_json::Value), KeyedError> {
    let given = [p.values.is_some(), p.range.is_some(), p.random.is_some()];
    if given.iter().filter(|g| **g).count() != 1 {
        return Err((
            key.to_string(),
            format!(
                "{key} ({}): give exactly one of `values` (a list), `range` ({{ start, stop, num, \
                 scale }}) or `random` ({{ low, high, count, scale }})",
                p.path
            ),
        ));
    }
    let count_ok = |k: &str, n: usize, what: &str| {
        if (1..=MAX_SWEEP_VALUES).contains(&n) {
            Ok(())
        } else {
            Err((
                k.to_string(),
                format!(
                    "{k} = {n} is outside the allowed range [1, {MAX_SWEEP_VALUES}]{}",
                    if n == 0 {
                        format!(" ({what} is empty)")
                    } else {
                        String::new()
                    }
                ),
            ))
        }
    };
    if let Some(values) = &p.values {
        let k = format!("{key}.values");
        if values.is_empty() {
            return Err((
                k.clone(),
                format!("{k} = [] is empty: give at least one value"),
            ));
        }
        count_ok(&k, values.len(), "the list")?;
        let shape = |v: &Value| match v {
            Value::Array(a) => format!("an array of {}", a.len()),
            Value::Integer(_) | Value::Float(_) => "a number".into(),
            other => format!("a {}", other.type_str()),
        };
        let first = shape(&values[0]);
        if let Some((j, v)) = values.iter().enumerate().find(|(_, v)| shape(v) != first) {
            return Err((
                k.clone(),
                format!(
                    "{k}: value {} is {} but value 1 is {first}: every value of a parameter has \
                     the same type",
                    j + 1,
                    shape(v)
                ),
            ));
        }
        return Ok((values.clone(), json!({"values": values.len()})));
    }
    let (lo_key, hi_key, lo, hi, n, scale, what, n_key) = match (&p.range, &p.random) {
        (Some(r), _) => (
            format!("{key}.range.start"),
            format!("{key}.range.stop"),
            &r.start,
            &r.stop,
            r.num,
            r.scale,
            "range",
            format!("{key}.range.num"),
        ),
        (None, Some(r)) => (
            format!("{key}.random.low"),
            format!("{key}.random.high"),
            &r.low,
            &r.high,
            r.count,
            r.scale,
            "random",
            format!("{key}.random.count"),
        ),
        _ => unreachable!("one of them is given"),
    };
    count_ok(&n_key, n, &format!("the {what}"))?;
    let number = |k: &String, v: &Value| {
        point(v)
            .filter(|(_, xs)| xs.iter().all(|x| x.is_finite()))
            .ok_or_else(|| {
                (
                    k.clone(),
                    format!(
                        "{k} = {}: expected a finite number or an array of them",
                        inline(v)
                    ),
                )
            })
    };
    let (vector, a) = number(&lo_key, lo)?;
    let (vector_b, b) = number(&hi_key, hi)?;
    if vector != vector_b || a.len() != b.len() {
        return Err((
            hi_key.clone(),
            format!(
                "{hi_key} = {} has another shape than {lo_key} = {}",
                inline(hi),
                inline(lo)
            ),
        ));
    }
    if scale == Scale::Log {
        if let Some(x) = a.iter().chain(&b).find(|x| **x <= 0.0) {
            return Err((
                format!("{key}.{what}.scale"),
                format!(
                    "{key}.{what}.scale = \"log\" needs positive bounds, but one is {}",
                    fmt_num(*x)
                ),
            ));
        }
    }
    if what == "random" {
        if let Some(c) = (0..a.len()).find(|&c| a[c] > b[c]) {
            return Err((
                hi_key.clone(),
                format!(
                    "{hi_key} = {} is below {lo_key} = {} (component {c})",
                    inline(hi),
                    inline(lo)
                ),
            ));
        }
    }
    if integer {
        if let Some(x) = a.iter().chain(&b).find(|x| x.fract() != 0.0) {
            return Err((
                lo_key.clone(),
                format!(
                    "{} is a whole number in the scenario: the bounds must be whole, found {}",
                    p.path,
                    fmt_num(*x)
                ),
            ));
        }
    }
    let map = |u: f64, c: usize| match scale {
        Scale::Linear => a[c] + (b[c] - a[c]) * u,
        Scale::Log => (a[c].ln() + (b[c].ln() - a[c].ln()) * u).exp(),
    };
    let mut values = Vec::with_capacity(n);
    if what == "range" {
        for k in 0..n {
            let xs: Vec<f64> = (0..a.len())
                .map(|c| match k {
                    0 => a[c],
                    _ if k + 1 == n => b[c],
                    _ => map(k as f64 / (n - 1) as f64, c),
                })
                .collect();
            if integer
                && xs
                    .iter()
                    .any(|x| (x - x.round()).abs() > 1e-9 * x.abs().max(1.0))
            {
                return Err((
                    n_key.clone(),
                    format!(
                        "{} is a whole number in the scenario, but the range gives {} at value {}; \
                         choose start, stop and num so that every value is whole",
                        p.path,
                        fmt_num(xs[0]),
                        k + 1
                    ),
                ));
            }
            let xs: Vec<f64> = if integer {
                xs.iter().map(|x| x.round()).collect()
            } else {
                xs
            };
            values.push(make_value(vector, &xs, integer));
        }
    } else {
        // One generator per parameter, from the sweep's seed and the parameter's position.
        let mut rng = SplitMix(seed ^ (i as u64 + 1).wrapping_mul(0xD1B5_4A32_D192_ED03));
        for _ in 0..n {
            let xs: Vec<f64> = (0..a.len())
                .map(|c| {
                    let u = rng.unit();
                    if integer {
                        // Uniform over the whole numbers low..=high.
                        (a[c] + (u * (b[c] - a[c] + 1.0)).floor()).min(b[c])
                    } else {
                        map(u, c)
                    }
                })
                .collect();
            values.push(make_value(vector, &xs, integer));
        }
    }
    Ok((
        values,
        json!({what: n, "scale": scale, "low": serde_json::to_value(lo).unwrap_or_default(),
               "high": serde_json::to_value(hi).unwrap_or_default()}),
    ))
}

/// The table columns of a parameter: one, or one per component of a vector of numbers.
fn columns_of(path: &str, values: &[Value]) -> Result<Vec<String>, String> {
    match &values[0] {
        Value::Array(a)
            if a.iter()
                .all(|x| matches!(x, Value::Integer(_) | Value::Float(_))) =>
        {
            if values
                .iter()
                .any(|v| !matches!(v, Value::Array(b) if b.len() == a.len()))
            {
                return Err(format!(
                    "{path}: every value must be an array of {} numbers, like the first",
                    a.len()
                ));
            }
            Ok((0..a.len()).map(|c| format!("{path}[{c}]")).collect())
        }
        _ => Ok(vec![path.to_string()]),
    }
}

/// The canonical text of a TOML value: keys sorted, numbers as the shortest text that reads
/// back exactly, strings JSON-escaped. Independent of serde's and toml's ordering and
/// formatting choices, so the same scenario gives the same text everywhere.
pub fn canonical(v: &Value, out: &mut String) {
    match v {
        Value::String(s) => out.push_str(&serde_json::to_string(s).expect("a string")),
        Value::Integer(i) => out.push_str(&i.to_string()),
        Value::Float(f) => {
            if f.is_finite() {
                out.push_str(&format!("{f:?}"));
            } else if f.is_nan() {
                out.push_str("nan");
            } else if *f > 0.0 {
                out.push_str("inf");
            } else {
                out.push_str("-inf");
            }
        }
        Value::Boolean(b) => out.push_str(if *b { "true" } else { "false" }),
        Value::Datetime(d) => {
            out.push_str(&serde_json::to_string(&d.to_string()).expect("a string"))
        }
        Value::Array(a) => {
            out.push('[');
            for (k, x) in a.iter().enumerate() {
                if k > 0 {
                    out.push(',');
                }
                canonical(x, out);
            }
            out.push(']');
        }
        Value::Table(t) => {
            let mut keys: Vec<&String> = t.keys().collect();
            keys.sort();
            out.push('{');
            for (k, key) in keys.into_iter().enumerate() {
                if k > 0 {
                    out.push(',');
                }
                out.push_str(&serde_json::to_string(key).expect("a string"));
                out.push(':');
                canonical(&t[key], out);
            }
            out.push('}');
        }
    }
}

/// 128-bit FNV-1a of `bytes`.
fn fnv1a128(bytes: &[u8]) -> u128 {
    const OFFSET: u128 = 0x6c62272e07bb014262b821756295c58d;
    const PRIME: u128 = 0x0000000001000000000000000000013B;
    bytes
        .iter()
        .fold(OFFSET, |h, &b| (h ^ u128::from(b)).wrapping_mul(PRIME))
}

/// The run id of a scenario text: the first `RUN_ID_LEN` hex digits of the 128-bit FNV-1a hash
/// of its canonical form (comments, key order and number spelling do not matter). A text that
/// does not parse hashes as it is.
pub fn run_id(text: &str) -> String {
    let hash = match toml::from_str::<Value>(text) {
        Ok(v) => {
            let mut s = String::new();
            canonical(&v, &mut s);
            fnv1a128(s.as_bytes())
        }
        Err(_) => fnv1a128(text.as_bytes()),
    };
    format!("{hash:032x}")[..RUN_ID_LEN].to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_ids_depend_on_content_only() {
        let a =
            "# a comment\n[time]\ndt = 1e-5\nduration = 1.0\n\n[rod]\nlength = 0.2\nname = \"x\"\n";
        let b = "[rod]\nname = \"x\"\nlength = 0.20\n[time]\nduration = 1.0\ndt = 0.00001\n";
        assert_eq!(run_id(a), run_id(b));
        assert_eq!(run_id(a).len(), RUN_ID_LEN);
        assert_ne!(run_id(a), run_id(&a.replace("0.2", "0.3")));
        // Integer and float spellings are different values in TOML, as serde reads them.
        assert_ne!(run_id("x = 1"), run_id("x = 1.0"));
        let mut s = String::new();
        canonical(&toml::from_str::<Value>(b).unwrap(), &mut s);
        assert_eq!(
            s,
            r#"{"rod":{"length":0.2,"name":"x"},"time":{"dt":1e-5,"duration":1.0}}"#
        );
    }

    #[test]
    fn splitmix_is_the_reference_generator() {
        // SplitMix64 (Steele, Lea, Flood 2014) from state 0: its published first outputs.
        let mut g = SplitMix(0);
        assert_eq!(g.next(), 0xe220a8397b1dcdaf);
        assert_eq!(g.next(), 0x6e789e6aa1b965f4);
        let u = SplitMix(1).unit();
        assert!((0.0..1.0).contains(&u));
    }

    fn parameter(text: &str) -> ParameterFile {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn ranges_hit_their_ends_and_log_ranges_are_geometric() {
        let p = parameter(
            "path = \"x\"\nrange = { start = 1e4, stop = 1e6, num = 3, scale = \"log\" }",
        );
        let (v, _) = values_of(&p, "parameter[0]", false, 0, 0).unwrap();
        let xs: Vec<f64> = v.iter().map(|x| x.as_float().unwrap()).collect();
        assert_eq!(xs[0], 1e4);
        assert_eq!(xs[2], 1e6);
        assert!((xs[1] / 1e5 - 1.0).abs() < 1e-12);
        let p =
            parameter("path = \"x\"\nrange = { start = [0.0, 1.0], stop = [1.0, 1.0], num = 5 }");
        let (v, _) = values_of(&p, "parameter[0]", false, 0, 0).unwrap();
        assert_eq!(inline(&v[2]), "[0.5, 1]");
        // Whole-number keys get whole numbers, or an error naming the value.
        let p = parameter("path = \"n\"\nrange = { start = 10, stop = 40, num = 4 }");
        let (v, _) = values_of(&p, "parameter[0]", true, 0, 0).unwrap();
        assert_eq!(v, [10, 20, 30, 40].map(Value::Integer));
        let p = parameter("path = \"n\"\nrange = { start = 10, stop = 41, num = 3 }");
        let (k, m) = values_of(&p, "parameter[0]", true, 0, 0).unwrap_err();
        assert_eq!(k, "parameter[0].range.num");
        assert!(m.contains("25.5"), "{m}");
    }

    #[test]
    fn random_samples_stay_in_bounds_and_depend_on_seed_and_position() {
        let p = parameter("path = \"x\"\nrandom = { low = 2.0, high = 3.0, count = 1000 }");
        let draw = |seed, i| values_of(&p, "p", false, seed, i).unwrap().0;
        let v = draw(5, 0);
        assert!(v
            .iter()
            .all(|x| (2.0..3.0).contains(&x.as_float().unwrap())));
        let mean = v.iter().map(|x| x.as_float().unwrap()).sum::<f64>() / 1000.0;
        // Uniform on [2, 3): mean 2.5, standard error 0.29 / sqrt(1000) = 0.009.
        assert!((mean - 2.5).abs() < 0.05, "{mean}");
        assert_eq!(v, draw(5, 0));
        assert_ne!(v, draw(6, 0));
        assert_ne!(v, draw(5, 1));
        let p = parameter("path = \"n\"\nrandom = { low = 1, high = 3, count = 300 }");
        let (v, _) = values_of(&p, "p", true, 1, 0).unwrap();
        for k in 1..=3 {
            assert!(v.contains(&Value::Integer(k)), "{k} never drawn");
        }
        assert!(v.iter().all(|x| matches!(x, Value::Integer(1..=3))));
    }
}
