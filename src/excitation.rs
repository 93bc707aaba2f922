//! Excitation signals of the thesis (Tables 4.3, 4.4, 4.5, 4.7, 4.9): per joint
//! u(t) = A(t)·cos(ω(t)·t + ϕ) with A(t) = A0 + A1·t and ω(t) = ω0 + ω1·t, read from a data
//! file (`model/excitation/<model>.toml`) so that a user's own tables are the same kind of
//! data. Numbers may be expressions as the thesis prints them (`"2.5/60"`, `"pi/2"`).

use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::path::Path;

/// Excitation files compiled into the binary: (model, text).
pub const BUNDLED: &[(&str, &str)] = &[(
    "freedom6s",
    include_str!("../model/excitation/freedom6s.toml"),
)];

/// A number or an arithmetic expression of numbers and `pi` (`+ - * /`, parentheses).
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum Value {
    /// A TOML number.
    Number(f64),
    /// An expression.
    Expr(String),
}

impl Value {
    /// Evaluate.
    ///
    /// # Errors
    /// A malformed expression, with the position; parentheses nested deeper than
    /// [`MAX_NESTING`]; a value that is not finite (NaN, or a division by zero such as
    /// `1/0`).
    pub fn eval(&self) -> Result<f64> {
        let v = match self {
            Value::Number(x) => *x,
            Value::Expr(s) => {
                let mut p = Arith {
                    s: s.as_bytes(),
                    i: 0,
                    depth: 0,
                };
                let v = p.sum()?;
                p.skip();
                if p.i != p.s.len() {
                    bail!("'{s}': unexpected '{}' at position {}", &s[p.i..], p.i + 1);
                }
                v
            }
        };
        if !v.is_finite() {
            let shown = match self {
                Value::Number(x) => x.to_string(),
                Value::Expr(s) => format!("'{s}'"),
            };
            bail!("{shown} is {v}: expected a finite number (a division by zero?)");
        }
        Ok(v)
    }
}

/// Deepest nesting of parentheses an expression may have.
pub const MAX_NESTING: usize = 64;

struct Arith<'a> {
    s: &'a [u8],
    i: usize,
    depth: usize,
}

impl Arith<'_> {
    fn skip(&mut self) {
        while self.i < self.s.len() && self.s[self.i] == b' ' {
            self.i += 1;
        }
    }
    fn peek(&mut self) -> Option<u8> {
        self.skip();
        self.s.get(self.i).copied()
    }
    fn sum(&mut self) -> Result<f64> {
        let mut v = self.product()?;
        while let Some(c @ (b'+' | b'-')) = self.peek() {
            self.i += 1;
            let r = self.product()?;
            v = if c == b'+' { v + r } else { v - r };
        }
        Ok(v)
    }
    fn product(&mut self) -> Result<f64> {
        let mut v = self.unary()?;
        while let Some(c @ (b'*' | b'/')) = self.peek() {
            self.i += 1;
            let r = self.unary()?;
            v = if c == b'*' { v * r } else { v / r };
        }
        Ok(v)
    }
    fn unary(&mut self) -> Result<f64> {
        match self.peek() {
            Some(b'-') => {
                self.i += 1;
                self.depth += 1;
                if self.depth > 4 * MAX_NESTING {
                    bail!(
                        "more than {} signs in a row at position {}",
                        4 * MAX_NESTING,
                        self.i
                    );
                }
                let v = -self.unary()?;
                self.depth -= 1;
                Ok(v)
            }
            Some(b'(') => {
                self.i += 1;
                self.depth += 1;
                if self.depth > MAX_NESTING {
                    bail!(
                        "parentheses nested deeper than {MAX_NESTING} at position {}",
                        self.i
                    );
                }
                let v = self.sum()?;
                self.depth -= 1;
                if self.peek() != Some(b')') {
                    bail!("expected ')' at position {}", self.i + 1);
                }
                self.i += 1;
                Ok(v)
            }
            Some(b'p') if self.s[self.i..].starts_with(b"pi") => {
                self.i += 2;
                Ok(std::f64::consts::PI)
            }
            _ => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_digit()
                        || matches!(self.s[self.i], b'.' | b'e' | b'E')
                        || (matches!(self.s[self.i], b'+' | b'-')
                            && self.i > start
                            && matches!(self.s[self.i - 1], b'e' | b'E')))
                {
                    self.i += 1;
                }
                let text = std::str::from_utf8(&self.s[start..self.i]).unwrap_or("");
                text.parse().map_err(|_| {
                    anyhow::anyhow!("expected a number or 'pi' at position {}", start + 1)
                })
            }
        }
    }
}

/// One joint's signal as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SignalSpec {
    joint: String,
    amplitude: [Value; 2],
    omega: [Value; 2],
    #[serde(default)]
    phase: Option<Value>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct TestSpec {
    name: String,
    #[serde(default = "yes")]
    used: bool,
    signals: Vec<SignalSpec>,
}

fn yes() -> bool {
    true
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct TableSpec {
    id: String,
    title: String,
    quantity: Quantity,
    test: Vec<TestSpec>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    model: String,
    table: Vec<TableSpec>,
}

/// What a table's signals are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    /// Commanded torques (N·m or N).
    Torque,
    /// Position commands (rad or m), for a closed loop.
    Position,
}

/// u(t) = (A0 + A1 t)·cos((ω0 + ω1 t)·t + ϕ) on one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Signal {
    /// Joint index in the model.
    pub joint: usize,
    /// A0 (N·m or rad), A1 (per s).
    pub amplitude: [f64; 2],
    /// ω0 (rad/s), ω1 (rad/s²).
    pub omega: [f64; 2],
    /// ϕ (rad).
    pub phase: f64,
}

impl Signal {
    /// Value at time `t` (s).
    pub fn value(&self, t: f64) -> f64 {
        let a = self.amplitude[0] + self.amplitude[1] * t;
        let w = self.omega[0] + self.omega[1] * t;
        a * (w * t + self.phase).cos()
    }
}

/// One test of a table: signals applied together.
#[derive(Debug, Clone)]
pub struct Test {
    /// Name (`J0-1`, `coupled`, …).
    pub name: String,
    /// False for the thesis's bracketed inputs (not used for optimisation).
    pub used: bool,
    /// Signals.
    pub signals: Vec<Signal>,
}

/// A thesis table (or a user's).
#[derive(Debug, Clone)]
pub struct Table {
    /// Table number (`4.7`).
    pub id: String,
    /// What it is.
    pub title: String,
    /// Torques or position commands.
    pub quantity: Quantity,
    /// Tests.
    pub tests: Vec<Test>,
}

/// An excitation file: the tables for one model.
#[derive(Debug, Clone)]
pub struct Excitations {
    /// Model name.
    pub model: String,
    /// Tables.
    pub tables: Vec<Table>,
}

impl Excitations {
    /// Read an excitation file for `model` (joint names resolve against it).
    ///
    /// # Errors
    /// Unreadable file, TOML error with line, unknown joint, malformed expression (each
    /// named by table, test and joint), a model other than `model`.
    pub fn load(path: &Path, model: &generated::Model) -> Result<Excitations> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read the excitation file", path.display()))?;
        Excitations::parse(&text, &path.display().to_string(), model)
    }

    /// The tables bundled in the binary for `model` (`model/excitation/<name>.toml`).
    ///
    /// # Errors
    /// The model has no bundled tables.
    pub fn bundled(model: &generated::Model) -> Result<Excitations> {
        match BUNDLED.iter().find(|(m, _)| *m == model.name) {
            Some((m, text)) => {
                Excitations::parse(text, &format!("model/excitation/{m}.toml"), model)
            }
            None => {
                bail!(
                "model '{}' has no bundled excitation tables (bundled: {}); give --excitation FILE",
                model.name,
                BUNDLED.iter().map(|(m, _)| *m).collect::<Vec<_>>().join(", ")
            )
            }
        }
    }

    /// Parse the text of an excitation file (`origin` names it in messages).
    ///
    /// # Errors
    /// As [`Excitations::load`].
    pub fn parse(text: &str, origin: &str, model: &generated::Model) -> Result<Excitations> {
        let spec: FileSpec =
            toml::from_str(text).map_err(|e| crate::util::toml_error(origin, text, &e))?;
        if spec.model != model.name {
            bail!(
                "{origin}: written for model '{}', not '{}'",
                spec.model,
                model.name
            );
        }
        let mut tables = Vec::new();
        for t in spec.table {
            let mut tests = Vec::new();
            for test in t.test {
                let mut signals = Vec::new();
                for s in test.signals {
                    let item = format!(
                        "{origin}: table {} test '{}' joint '{}'",
                        t.id, test.name, s.joint
                    );
                    let joint = model
                        .joints
                        .iter()
                        .position(|j| *j == s.joint)
                        .with_context(|| {
                            format!(
                                "{item}: unknown joint (model has {})",
                                model.joints.join(", ")
                            )
                        })?;
                    let ev = |v: &Value| v.eval().with_context(|| item.clone());
                    signals.push(Signal {
                        joint,
                        amplitude: [ev(&s.amplitude[0])?, ev(&s.amplitude[1])?],
                        omega: [ev(&s.omega[0])?, ev(&s.omega[1])?],
                        phase: s.phase.as_ref().map(ev).transpose()?.unwrap_or(0.0),
                    });
                }
                tests.push(Test {
                    name: test.name,
                    used: test.used,
                    signals,
                });
            }
            tables.push(Table {
                id: t.id,
                title: t.title,
                quantity: t.quantity,
                tests,
            });
        }
        Ok(Excitations {
            model: spec.model,
            tables,
        })
    }

    /// A table by id.
    ///
    /// # Errors
    /// No such table (the ids present are listed).
    pub fn table(&self, id: &str) -> Result<&Table> {
        self.tables.iter().find(|t| t.id == id).with_context(|| {
            format!(
                "no table '{id}' for model '{}' (tables: {})",
                self.model,
                self.tables
                    .iter()
                    .map(|t| t.id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
    }
}

impl Table {
    /// A test by name; with `None`, the table's only test.
    ///
    /// # Errors
    /// No such test, or several and none named (the names are listed).
    pub fn test(&self, name: Option<&str>) -> Result<&Test> {
        let names = || {
            self.tests
                .iter()
                .map(|t| t.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        match name {
            Some(n) => self.tests.iter().find(|t| t.name == n).with_context(|| {
                format!("table {} has no test '{n}' (tests: {})", self.id, names())
            }),
            None if self.tests.len() == 1 => Ok(&self.tests[0]),
            None => bail!(
                "table {} has {} tests; choose one with --test (tests: {})",
                self.id,
                self.tests.len(),
                names()
            ),
        }
    }
}

impl Test {
    /// Sample the test on `nj` joints at `rate` Hz for `duration` s (samples at k/rate,
    /// k = 0..=duration·rate), applying only the signals of joints in `free`. Returns the
    /// times, one column per joint (zero where nothing is applied), and the joints whose
    /// signals were left out because they are not free.
    pub fn sample(
        &self,
        nj: usize,
        free: &[usize],
        duration: f64,
        rate: f64,
    ) -> (Vec<f64>, Vec<Vec<f64>>, Vec<usize>) {
        let n = (duration * rate).round() as usize + 1;
        let t: Vec<f64> = (0..n).map(|k| k as f64 / rate).collect();
        let mut cols = vec![vec![0.0; n]; nj];
        let mut left_out = Vec::new();
        for s in &self.signals {
            if !free.contains(&s.joint) {
                left_out.push(s.joint);
                continue;
            }
            for (k, &tk) in t.iter().enumerate() {
                cols[s.joint][k] += s.value(tk);
            }
        }
        (t, cols, left_out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expressions_evaluate_as_printed_in_the_thesis() {
        let e = |s: &str| Value::Expr(s.into()).eval().unwrap();
        assert_eq!(e("2.5/60"), 2.5 / 60.0);
        assert_eq!(e("-0.002/60"), -0.002 / 60.0);
        assert_eq!(e("pi/2"), std::f64::consts::FRAC_PI_2);
        assert_eq!(e("1 + 2*(3 - 1e-1)"), 1.0 + 2.0 * 2.9);
        assert!(Value::Expr("2/".into()).eval().is_err());
        assert!(Value::Expr("2 x".into()).eval().is_err());
    }

    #[test]
    fn a_chirp_has_the_tables_instantaneous_form() {
        // Table 4.7, joint 4: A = 0.0045 − (0.002/60) t, ω = 0.5 + (2.5/60) t, ϕ = π/2.
        let s = Signal {
            joint: 4,
            amplitude: [0.0045, -0.002 / 60.0],
            omega: [0.5, 2.5 / 60.0],
            phase: std::f64::consts::FRAC_PI_2,
        };
        let t: f64 = 30.0;
        let expect = (0.0045 - 0.001) * ((0.5 + 1.25) * t + std::f64::consts::FRAC_PI_2).cos();
        assert!((s.value(t) - expect).abs() < 1e-15);
        assert!(s.value(0.0).abs() < 1e-18);
    }
}
