//! The fuzzy wall controller of thesis 5.4–5.5: two inputs (joint position q, velocity q̇),
//! triangular membership functions forming a partition of unity, product AND, singleton
//! outputs, weighted-average defuzzification (2.3). Under these three conditions the
//! controller is the bilinear interpolation of its rule table, the fuzzy associative memory
//! (FAM), and Kubica's mapping (5.3) makes it reproduce a linear law exactly (5.4).
//!
//! Rule tables load from and save to fuzzylite's FLL and MATLAB's FIS formats (a zero-order
//! Takagi–Sugeno system: `Constant`/`constant` output terms, weighted average), so they open
//! in those tools unchanged.

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// The membership functions of one input: triangles peaking at `peaks` whose feet are the
/// neighbouring peaks, so at most two are non-zero and they sum to one everywhere (thesis
/// 5.4, conditions 1–3). Beyond the first and last peaks the input saturates (fuzzylite's
/// `lock-range`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Partition {
    /// Input name (`q`, `dq`).
    pub name: String,
    /// Membership-function labels in increasing order (`N8` … `Z0` … `P4`).
    pub labels: Vec<String>,
    /// Peak of each membership function (rad or rad/s), strictly increasing.
    pub peaks: Vec<f64>,
}

impl Partition {
    /// A partition, checked.
    ///
    /// # Errors
    /// Fewer than two functions, labels and peaks of different lengths, duplicate labels,
    /// peaks not finite or not strictly increasing (the offending label named).
    pub fn new(name: &str, labels: Vec<String>, peaks: Vec<f64>) -> Result<Partition> {
        if labels.len() != peaks.len() {
            bail!(
                "input '{name}': {} labels but {} peaks",
                labels.len(),
                peaks.len()
            );
        }
        if peaks.len() < 2 {
            bail!("input '{name}': at least two membership functions are needed");
        }
        for i in 0..peaks.len() {
            if !peaks[i].is_finite() {
                bail!(
                    "input '{name}': peak of '{}' is not a finite number",
                    labels[i]
                );
            }
            if i > 0 && peaks[i] <= peaks[i - 1] {
                bail!(
                    "input '{name}': peaks must increase strictly, but '{}' = {} follows '{}' = {}",
                    labels[i],
                    peaks[i],
                    labels[i - 1],
                    peaks[i - 1]
                );
            }
            if labels[..i].contains(&labels[i]) {
                bail!("input '{name}': label '{}' appears twice", labels[i]);
            }
        }
        Ok(Partition {
            name: name.to_string(),
            labels,
            peaks,
        })
    }

    /// Number of membership functions.
    pub fn len(&self) -> usize {
        self.peaks.len()
    }

    /// Always false (a partition has at least two functions).
    pub fn is_empty(&self) -> bool {
        self.peaks.is_empty()
    }

    /// Index of a label.
    ///
    /// # Errors
    /// Unknown label (the known ones listed).
    pub fn index(&self, label: &str) -> Result<usize> {
        self.labels
            .iter()
            .position(|l| l == label)
            .with_context(|| {
                format!(
                    "input '{}' has no membership function '{label}' (it has {})",
                    self.name,
                    self.labels.join(", ")
                )
            })
    }

    /// The cell of `x`: `(i, μ_i)` with x (saturated) between peaks i and i + 1, μ_i the
    /// membership of function i and 1 − μ_i that of i + 1 (5.2).
    pub fn cell(&self, x: f64) -> (usize, f64) {
        let n = self.peaks.len();
        let x = x.clamp(self.peaks[0], self.peaks[n - 1]);
        // Binary search for the last peak ≤ x, capped so that i + 1 exists.
        let i = self.peaks.partition_point(|&p| p <= x).clamp(1, n - 1) - 1;
        let (a, b) = (self.peaks[i], self.peaks[i + 1]);
        (i, (b - x) / (b - a))
    }

    /// Membership of `x` (saturated) in function `j`: the triangle (p_{j−1}, p_j, p_{j+1})
    /// with a shoulder at the ends.
    pub fn membership(&self, j: usize, x: f64) -> f64 {
        let n = self.peaks.len();
        let x = x.clamp(self.peaks[0], self.peaks[n - 1]);
        let p = self.peaks[j];
        if x == p {
            1.0
        } else if x < p {
            if j == 0 {
                return 0.0;
            }
            let a = self.peaks[j - 1];
            ((x - a) / (p - a)).max(0.0)
        } else {
            if j + 1 == n {
                return 0.0;
            }
            let c = self.peaks[j + 1];
            ((c - x) / (c - p)).max(0.0)
        }
    }
}

/// A rule modification of thesis Figure 5.6: every rule in the cells `position` × `velocity`
/// takes `factor` times the *unmodified* (Kubica) value of the rule at `like` =
/// (position label, velocity label). "N5·2" of the figure is `like = ["N2", "N3"]` (the
/// figure's rule N⁵ sits at N²_q, N³_dq), `factor = 2`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Modification {
    /// Position labels of the modified rules.
    pub position: Vec<String>,
    /// Velocity labels of the modified rules.
    pub velocity: Vec<String>,
    /// The rule whose value is copied: [position label, velocity label].
    pub like: [String; 2],
    /// Factor on the copied value (default 1).
    #[serde(default = "one")]
    pub factor: f64,
    /// Why (kept in reports).
    #[serde(default)]
    pub note: String,
}

/// Triangle terms of one input as read from a file: (label, [a, b, c]).
type Terms = Vec<(String, [f64; 3])>;

fn one() -> f64 {
    1.0
}

/// A two-input fuzzy controller: the FAM `rules[i][j]` is the singleton output (N·m) of the
/// rule "if q is position.labels\[i\] and q̇ is velocity.labels\[j\]".
#[derive(Debug, Clone, PartialEq)]
pub struct Fam {
    /// Position input (rad).
    pub position: Partition,
    /// Velocity input (rad/s).
    pub velocity: Partition,
    /// Rule outputs, `rules[i][j]`, shape position.len() × velocity.len() (N·m).
    pub rules: Vec<Vec<f64>>,
}

impl Fam {
    /// Kubica's mapping (thesis 5.3): every rule takes the value of `law` at its peaks,
    /// B = law(p_i, v_j). For a linear law the controller then equals the law everywhere
    /// inside the universe (5.4).
    pub fn kubica(position: Partition, velocity: Partition, law: impl Fn(f64, f64) -> f64) -> Fam {
        let rules = position
            .peaks
            .iter()
            .map(|&p| velocity.peaks.iter().map(|&v| law(p, v)).collect())
            .collect();
        Fam {
            position,
            velocity,
            rules,
        }
    }

    /// Controller output at (q, q̇): the weighted average (2.3) of the four rules of the
    /// cell with product AND, which under the partition of unity is the bilinear
    /// interpolation of the table (5.4). Inputs beyond the universe saturate.
    pub fn output(&self, q: f64, qd: f64) -> f64 {
        let (i, a) = self.position.cell(q);
        let (j, b) = self.velocity.cell(qd);
        let r0 = &self.rules[i];
        let r1 = &self.rules[i + 1];
        a * (b * r0[j] + (1.0 - b) * r0[j + 1]) + (1.0 - a) * (b * r1[j] + (1.0 - b) * r1[j + 1])
    }

    /// The same output computed the long way, as fuzzylite or MATLAB do: every rule's
    /// firing strength μ_i(q)·μ_j(q̇), weighted average over all 169 rules. For tests and
    /// for tables whose memberships were edited outside this crate.
    pub fn output_by_inference(&self, q: f64, qd: f64) -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..self.position.len() {
            let mi = self.position.membership(i, q);
            if mi == 0.0 {
                continue;
            }
            for j in 0..self.velocity.len() {
                let w = mi * self.velocity.membership(j, qd);
                num += w * self.rules[i][j];
                den += w;
            }
        }
        num / den
    }

    /// Apply rule modifications (Figure 5.6); references read the table as it was before
    /// any of them.
    ///
    /// # Errors
    /// A label that is not a membership function of its input (named with the list).
    pub fn modify(&mut self, mods: &[Modification]) -> Result<()> {
        let original = self.rules.clone();
        for (k, m) in mods.iter().enumerate() {
            let ctx = || format!("rule modification {} ({})", k + 1, m.note);
            let (ri, rj) = (
                self.position.index(&m.like[0]).with_context(ctx)?,
                self.velocity.index(&m.like[1]).with_context(ctx)?,
            );
            if !m.factor.is_finite() {
                bail!("{}: factor is not a finite number", ctx());
            }
            let value = m.factor * original[ri][rj];
            for p in &m.position {
                let i = self.position.index(p).with_context(ctx)?;
                for v in &m.velocity {
                    let j = self.velocity.index(v).with_context(ctx)?;
                    self.rules[i][j] = value;
                }
            }
        }
        Ok(())
    }

    /// Rule output range (min, max) (N·m).
    pub fn range(&self) -> (f64, f64) {
        let all = self.rules.iter().flatten().copied();
        let lo = all.clone().fold(f64::INFINITY, f64::min);
        let hi = all.fold(f64::NEG_INFINITY, f64::max);
        (lo, hi)
    }

    fn term(p: &Partition, j: usize) -> (f64, f64, f64) {
        let n = p.len();
        let b = p.peaks[j];
        let a = if j == 0 { b } else { p.peaks[j - 1] };
        let c = if j + 1 == n { b } else { p.peaks[j + 1] };
        (a, b, c)
    }

    fn rule_name(&self, i: usize, j: usize) -> String {
        format!("r_{}_{}", self.position.labels[i], self.velocity.labels[j])
    }

    /// The controller as a fuzzylite FLL engine (fuzzylite 6): inputs with `Triangle`
    /// terms and `lock-range: true`, one `Constant` output term per rule, `AlgebraicProduct`
    /// conjunction, `WeightedAverage` defuzzifier.
    pub fn to_fll(&self, engine: &str) -> String {
        let mut s = format!("Engine: {engine}\n");
        s += "description: virtual wall FAM (lockstep; thesis 5.4-5.5)\n";
        for p in [&self.position, &self.velocity] {
            s += &format!(
                "InputVariable: {}\n  enabled: true\n  range: {:e} {:e}\n  lock-range: true\n",
                p.name,
                p.peaks[0],
                p.peaks[p.len() - 1]
            );
            for j in 0..p.len() {
                let (a, b, c) = Self::term(p, j);
                s += &format!("  term: {} Triangle {a:e} {b:e} {c:e}\n", p.labels[j]);
            }
        }
        let (lo, hi) = self.range();
        s += &format!(
            "OutputVariable: u\n  enabled: true\n  range: {lo:e} {hi:e}\n  lock-range: false\n  aggregation: none\n  defuzzifier: WeightedAverage Automatic\n  default: nan\n  lock-previous: false\n"
        );
        for i in 0..self.position.len() {
            for j in 0..self.velocity.len() {
                s += &format!(
                    "  term: {} Constant {:e}\n",
                    self.rule_name(i, j),
                    self.rules[i][j]
                );
            }
        }
        s += "RuleBlock: fam\n  enabled: true\n  conjunction: AlgebraicProduct\n  disjunction: none\n  implication: none\n  activation: General\n";
        for i in 0..self.position.len() {
            for j in 0..self.velocity.len() {
                s += &format!(
                    "  rule: if {} is {} and {} is {} then u is {}\n",
                    self.position.name,
                    self.position.labels[i],
                    self.velocity.name,
                    self.velocity.labels[j],
                    self.rule_name(i, j)
                );
            }
        }
        s
    }

    /// The controller as a MATLAB Fuzzy Logic Toolbox FIS file (Sugeno, `prod` AND,
    /// `wtaver` defuzzification, `trimf` inputs, one `constant` output per rule).
    pub fn to_fis(&self, name: &str) -> String {
        let (np, nv) = (self.position.len(), self.velocity.len());
        let mut s = format!(
            "[System]\nName='{name}'\nType='sugeno'\nVersion=2.0\nNumInputs=2\nNumOutputs=1\nNumRules={}\nAndMethod='prod'\nOrMethod='probor'\nImpMethod='prod'\nAggMethod='sum'\nDefuzzMethod='wtaver'\n",
            np * nv
        );
        for (k, p) in [&self.position, &self.velocity].into_iter().enumerate() {
            s += &format!(
                "\n[Input{}]\nName='{}'\nRange=[{:e} {:e}]\nNumMFs={}\n",
                k + 1,
                p.name,
                p.peaks[0],
                p.peaks[p.len() - 1],
                p.len()
            );
            for j in 0..p.len() {
                let (a, b, c) = Self::term(p, j);
                s += &format!(
                    "MF{}='{}':'trimf',[{a:e} {b:e} {c:e}]\n",
                    j + 1,
                    p.labels[j]
                );
            }
        }
        let (lo, hi) = self.range();
        s += &format!(
            "\n[Output1]\nName='u'\nRange=[{lo:e} {hi:e}]\nNumMFs={}\n",
            np * nv
        );
        for i in 0..np {
            for j in 0..nv {
                s += &format!(
                    "MF{}='{}':'constant',[{:e}]\n",
                    i * nv + j + 1,
                    self.rule_name(i, j),
                    self.rules[i][j]
                );
            }
        }
        s += "\n[Rules]\n";
        for i in 0..np {
            for j in 0..nv {
                s += &format!("{} {}, {} (1) : 1\n", i + 1, j + 1, i * nv + j + 1);
            }
        }
        s
    }

    /// Read a rule table from fuzzylite FLL text (`origin` names it in errors). Accepts the
    /// subset [`Fam::to_fll`] writes: two inputs with `Triangle` terms forming a partition of
    /// unity, `Constant` output terms, one rule per pair of input terms with `and`.
    ///
    /// # Errors
    /// Anything else, with the line number: unknown term shape, triangles that are not a
    /// partition of unity, a rule on an unknown term, a missing or repeated rule.
    pub fn from_fll(text: &str, origin: &str) -> Result<Fam> {
        let mut inputs: Vec<(String, Terms)> = Vec::new();
        let mut outputs: HashMap<String, f64> = HashMap::new();
        let mut rules: Vec<(usize, String, String, String)> = Vec::new();
        let mut section = "";
        for (n, raw) in text.lines().enumerate() {
            let line_no = n + 1;
            let line = raw.split('#').next().unwrap_or("").trim();
            let err = |what: &str| anyhow::anyhow!("{origin}:{line_no}: {what}: '{line}'");
            if line.is_empty() {
                continue;
            }
            let (key, rest) = line
                .split_once(':')
                .map_or((line, ""), |(k, r)| (k.trim(), r.trim()));
            match key {
                "InputVariable" => {
                    section = "input";
                    inputs.push((rest.to_string(), Vec::new()));
                }
                "OutputVariable" => section = "output",
                "RuleBlock" => section = "rules",
                "term" => {
                    let f: Vec<&str> = rest.split_whitespace().collect();
                    let num = |s: &str| s.parse::<f64>().map_err(|_| err("expected a number"));
                    match section {
                        "input" => {
                            if f.len() != 5 || f[1] != "Triangle" {
                                return Err(err("expected 'term: NAME Triangle a b c'"));
                            }
                            let abc = [num(f[2])?, num(f[3])?, num(f[4])?];
                            if let Some(last) = inputs.last_mut() {
                                last.1.push((f[0].to_string(), abc));
                            }
                        }
                        "output" => {
                            if f.len() != 3 || f[1] != "Constant" {
                                return Err(err(
                                    "expected 'term: NAME Constant value' (singleton outputs)",
                                ));
                            }
                            outputs.insert(f[0].to_string(), num(f[2])?);
                        }
                        _ => return Err(err("a term outside a variable")),
                    }
                }
                "rule" => {
                    let w: Vec<&str> = rest.split_whitespace().collect();
                    if w.len() != 12
                        || w[0] != "if"
                        || w[2] != "is"
                        || w[4] != "and"
                        || w[6] != "is"
                        || w[8] != "then"
                        || w[10] != "is"
                    {
                        return Err(err(
                            "expected 'rule: if IN1 is A and IN2 is B then OUT is C'",
                        ));
                    }
                    let (a, b) = if inputs.first().is_some_and(|x| x.0 == w[1]) {
                        (w[3], w[7])
                    } else {
                        (w[7], w[3])
                    };
                    rules.push((line_no, a.to_string(), b.to_string(), w[11].to_string()));
                }
                "conjunction" if rest != "AlgebraicProduct" => {
                    return Err(err(
                        "only 'conjunction: AlgebraicProduct' is the thesis's product AND",
                    ))
                }
                "defuzzifier" if !rest.starts_with("WeightedAverage") => {
                    return Err(err("only the WeightedAverage defuzzifier is supported"))
                }
                _ => {}
            }
        }
        Self::assemble(origin, &inputs, &outputs, rules)
    }

    /// The table from parsed file contents (FLL or FIS): two inputs whose triangles must
    /// form a partition of unity, output singletons by name, and rules
    /// `(line, position label, velocity label, output name)`; every cell exactly once.
    fn assemble(
        origin: &str,
        inputs: &[(String, Terms)],
        outputs: &HashMap<String, f64>,
        rules: Vec<(usize, String, String, String)>,
    ) -> Result<Fam> {
        if inputs.len() != 2 {
            bail!(
                "{origin}: expected two input variables, found {}",
                inputs.len()
            );
        }
        let part = |(name, terms): &(String, Terms)| -> Result<Partition> {
            let p = Partition::new(
                name,
                terms.iter().map(|t| t.0.clone()).collect(),
                terms.iter().map(|t| t.1[1]).collect(),
            )
            .with_context(|| origin.to_string())?;
            for (j, (label, abc)) in terms.iter().enumerate() {
                let want = Self::term(&p, j);
                let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * (1.0 + y.abs());
                if !(close(abc[0], want.0) && close(abc[2], want.2)) {
                    bail!(
                        "{origin}: input '{name}', term '{label}': triangle ({}, {}, {}) does not end at its neighbours' peaks ({}, {}): not a partition of unity",
                        abc[0], abc[1], abc[2], want.0, want.2
                    );
                }
            }
            Ok(p)
        };
        let (position, velocity) = (part(&inputs[0])?, part(&inputs[1])?);
        let mut table = vec![vec![f64::NAN; velocity.len()]; position.len()];
        for (line_no, a, b, c) in rules {
            let i = position
                .index(&a)
                .with_context(|| format!("{origin}:{line_no}"))?;
            let j = velocity
                .index(&b)
                .with_context(|| format!("{origin}:{line_no}"))?;
            let v = *outputs
                .get(&c)
                .with_context(|| format!("{origin}:{line_no}: no output term '{c}'"))?;
            if !table[i][j].is_nan() {
                bail!("{origin}:{line_no}: a second rule for ({a}, {b})");
            }
            table[i][j] = v;
        }
        for (i, row) in table.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                if v.is_nan() {
                    bail!(
                        "{origin}: no rule for ({} is {}, {} is {}): the table must be complete",
                        position.name,
                        position.labels[i],
                        velocity.name,
                        velocity.labels[j]
                    );
                }
            }
        }
        Ok(Fam {
            position,
            velocity,
            rules: table,
        })
    }

    /// Read a rule table from a MATLAB FIS file (the subset [`Fam::to_fis`] writes).
    ///
    /// # Errors
    /// As [`Fam::from_fll`], with the line number.
    pub fn from_fis(text: &str, origin: &str) -> Result<Fam> {
        let mut section = String::new();
        let mut inputs: Vec<(String, Terms)> = Vec::new();
        let mut consts: Vec<f64> = Vec::new();
        let mut rules: Vec<(usize, usize, usize, usize)> = Vec::new();
        for (n, raw) in text.lines().enumerate() {
            let line_no = n + 1;
            let line = raw.trim();
            let err = |what: &str| anyhow::anyhow!("{origin}:{line_no}: {what}: '{line}'");
            if line.is_empty() || line.starts_with('%') {
                continue;
            }
            if line.starts_with('[') && line.ends_with(']') && !line.contains('=') {
                section = line[1..line.len() - 1].to_string();
                if section.starts_with("Input") {
                    inputs.push((String::new(), Vec::new()));
                }
                continue;
            }
            if section == "Rules" {
                // "i j, k (w) : c"
                let cleaned = line.replace([',', '(', ')', ':'], " ");
                let f: Vec<&str> = cleaned.split_whitespace().collect();
                let int = |s: &str| {
                    s.parse::<usize>()
                        .map_err(|_| err("expected a rule 'i j, k (w) : 1'"))
                };
                if f.len() != 5 || f[4] != "1" {
                    return Err(err("expected a rule 'i j, k (w) : 1' with AND"));
                }
                rules.push((line_no, int(f[0])?, int(f[1])?, int(f[2])?));
                continue;
            }
            let Some((key, value)) = line.split_once('=') else {
                return Err(err("expected key=value"));
            };
            let value = value.trim();
            let unquote = |s: &str| s.trim().trim_matches('\'').to_string();
            // MFk='name':'shape',[numbers]: the label and `count` numbers of that shape.
            let mf = |value: &str, shape: &str, count: usize| -> Result<(String, Vec<f64>)> {
                let form = || err(&format!("expected MFk='name':'{shape}',[{count} numbers]"));
                let (label, rest) = value.split_once(':').ok_or_else(form)?;
                let (kind, params) = rest.split_once(',').ok_or_else(form)?;
                if unquote(kind) != shape {
                    return Err(err(&format!("only '{shape}' membership functions here")));
                }
                let inner = params.trim().trim_start_matches('[').trim_end_matches(']');
                let v = inner
                    .split_whitespace()
                    .map(|x| x.parse::<f64>().map_err(|_| form()))
                    .collect::<Result<Vec<f64>>>()?;
                if v.len() != count {
                    return Err(form());
                }
                Ok((unquote(label), v))
            };
            match (section.as_str(), key.trim()) {
                ("System", "Type") if unquote(value) != "sugeno" => {
                    return Err(err("only Sugeno systems (singleton outputs) are supported"))
                }
                ("System", "AndMethod") if unquote(value) != "prod" => {
                    return Err(err("only AndMethod='prod' (the thesis's product AND)"))
                }
                ("System", "DefuzzMethod") if unquote(value) != "wtaver" => {
                    return Err(err("only DefuzzMethod='wtaver' (weighted average)"))
                }
                (s, "Name") if s.starts_with("Input") => {
                    if let Some(last) = inputs.last_mut() {
                        last.0 = unquote(value);
                    }
                }
                (s, k) if s.starts_with("Input") && k.starts_with("MF") => {
                    let (label, v) = mf(value, "trimf", 3)?;
                    if let Some(last) = inputs.last_mut() {
                        last.1.push((label, [v[0], v[1], v[2]]));
                    }
                }
                ("Output1", k) if k.starts_with("MF") => {
                    consts.push(mf(value, "constant", 1)?.1[0])
                }
                _ => {}
            }
        }
        let label = |input: usize, k: usize, line_no: usize| -> Result<String> {
            inputs
                .get(input)
                .and_then(|x| x.1.get(k.wrapping_sub(1)))
                .map(|t| t.0.clone())
                .with_context(|| format!("{origin}:{line_no}: input {} has no MF{k}", input + 1))
        };
        let outputs: HashMap<String, f64> = consts
            .iter()
            .enumerate()
            .map(|(k, &c)| (format!("MF{}", k + 1), c))
            .collect();
        let rules = rules
            .iter()
            .map(|&(line_no, i, j, k)| {
                Ok((
                    line_no,
                    label(0, i, line_no)?,
                    label(1, j, line_no)?,
                    format!("MF{k}"),
                ))
            })
            .collect::<Result<_>>()?;
        Self::assemble(origin, &inputs, &outputs, rules)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(peaks: &[f64]) -> Partition {
        Partition::new(
            "x",
            (0..peaks.len()).map(|i| format!("M{i}")).collect(),
            peaks.to_vec(),
        )
        .unwrap()
    }

    #[test]
    fn memberships_sum_to_one_and_cells_agree() {
        let p = part(&[-1.0, -0.1, 0.0, 0.3, 2.0]);
        for k in 0..=400 {
            let x = -1.5 + 4.0 * k as f64 / 400.0;
            let s: f64 = (0..p.len()).map(|j| p.membership(j, x)).sum();
            assert!((s - 1.0).abs() < 1e-14, "x = {x}: Σμ = {s}");
            let (i, a) = p.cell(x);
            assert!((p.membership(i, x) - a).abs() < 1e-14);
            assert!((p.membership(i + 1, x) - (1.0 - a)).abs() < 1e-14);
        }
    }

    #[test]
    fn bad_partitions_are_refused() {
        let l = |n: usize| (0..n).map(|i| format!("M{i}")).collect::<Vec<_>>();
        let e = Partition::new("q", l(3), vec![0.0, 0.0, 1.0]).unwrap_err();
        assert!(e.to_string().contains("'M1' = 0 follows 'M0'"), "{e}");
        assert!(Partition::new("q", l(2), vec![0.0]).is_err());
        assert!(Partition::new("q", vec!["A".into(), "A".into()], vec![0.0, 1.0]).is_err());
    }
}
