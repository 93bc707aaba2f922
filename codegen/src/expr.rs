//! Scalar expressions of the model file (DH entries, frame transforms, inertial symbols).
//!
//! The grammar is small on purpose: numbers, identifiers, `+ - * / ^`, parentheses, unary
//! minus and the functions `sin`, `cos`, `sqrt`. `pi` is π. Every identifier must be a joint
//! variable, a constant of the model or an inertial parameter symbol; anything else is an
//! error naming the field. Parsing is ours (not Symbolica's) so that a malformed expression
//! is reported with its position and the field it came from before any symbolic work starts.

use std::collections::BTreeMap;
use std::fmt;

/// Parsed scalar expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A real number literal.
    Num(f64),
    /// A named quantity (joint variable, constant, inertial symbol or `pi`).
    Sym(String),
    /// Sum of the two operands.
    Add(Box<Expr>, Box<Expr>),
    /// Difference of the two operands.
    Sub(Box<Expr>, Box<Expr>),
    /// Product of the two operands.
    Mul(Box<Expr>, Box<Expr>),
    /// Quotient of the two operands.
    Div(Box<Expr>, Box<Expr>),
    /// Power with an integer exponent.
    Pow(Box<Expr>, i32),
    /// Negation.
    Neg(Box<Expr>),
    /// A function of one argument (`sin`, `cos`, `sqrt`).
    Fun(Func, Box<Expr>),
}

/// Functions allowed in model expressions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Func {
    /// Sine (argument in rad).
    Sin,
    /// Cosine (argument in rad).
    Cos,
    /// Square root.
    Sqrt,
}

/// Deepest nesting of parentheses (or longest run of prefix signs) an expression may have.
pub const MAX_NESTING: usize = 64;

/// A parse error with the byte offset where it happened.
#[derive(Debug, Clone, PartialEq)]
pub struct ParseError {
    /// Byte offset in the expression text.
    pub at: usize,
    /// What was expected.
    pub message: String,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (at character {})", self.message, self.at + 1)
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Op(char),
}

fn tokenize(s: &str) -> Result<Vec<(usize, Tok)>, ParseError> {
    let b = s.as_bytes();
    let mut i = 0;
    let mut out = Vec::new();
    while i < b.len() {
        let ch = b[i] as char;
        if ch.is_ascii_whitespace() {
            i += 1;
        } else if ch.is_ascii_digit() || ch == '.' {
            let start = i;
            while i < b.len() && ((b[i] as char).is_ascii_digit() || b[i] == b'.') {
                i += 1;
            }
            if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
                let mut j = i + 1;
                if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
                    j += 1;
                }
                if j < b.len() && (b[j] as char).is_ascii_digit() {
                    i = j;
                    while i < b.len() && (b[i] as char).is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let text = &s[start..i];
            let v: f64 = text.parse().map_err(|_| ParseError {
                at: start,
                message: format!("malformed number '{text}'"),
            })?;
            out.push((start, Tok::Num(v)));
        } else if ch.is_ascii_alphabetic() || ch == '_' {
            let start = i;
            while i < b.len() && ((b[i] as char).is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            out.push((start, Tok::Ident(s[start..i].to_string())));
        } else if "+-*/^()".contains(ch) {
            out.push((i, Tok::Op(ch)));
            i += 1;
        } else {
            return Err(ParseError {
                at: i,
                message: format!("unexpected character '{ch}'"),
            });
        }
    }
    Ok(out)
}

struct Parser<'a> {
    toks: &'a [(usize, Tok)],
    pos: usize,
    len: usize,
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.pos).map(|t| &t.1)
    }
    fn at(&self) -> usize {
        self.toks.get(self.pos).map(|t| t.0).unwrap_or(self.len)
    }
    fn err<T>(&self, message: impl Into<String>) -> Result<T, ParseError> {
        Err(ParseError {
            at: self.at(),
            message: message.into(),
        })
    }
    fn expr(&mut self) -> Result<Expr, ParseError> {
        let mut lhs = self.term()?;
        while let Some(Tok::Op(c @ ('+' | '-'))) = self.peek() {
            let c = *c;
            self.pos += 1;
            let rhs = self.term()?;
            lhs = if c == '+' {
                Expr::Add(Box::new(lhs), Box::new(rhs))
            } else {
                Expr::Sub(Box::new(lhs), Box::new(rhs))
            };
        }
        Ok(lhs)
    }
    fn term(&mut self) -> Result<Expr, ParseError> {
        let mut lhs = self.unary()?;
        while let Some(Tok::Op(c @ ('*' | '/'))) = self.peek() {
            let c = *c;
            self.pos += 1;
            let rhs = self.unary()?;
            lhs = if c == '*' {
                Expr::Mul(Box::new(lhs), Box::new(rhs))
            } else {
                Expr::Div(Box::new(lhs), Box::new(rhs))
            };
        }
        Ok(lhs)
    }
    fn unary(&mut self) -> Result<Expr, ParseError> {
        match self.peek() {
            Some(Tok::Op('-')) => {
                self.pos += 1;
                Ok(Expr::Neg(Box::new(self.unary()?)))
            }
            Some(Tok::Op('+')) => {
                self.pos += 1;
                self.unary()
            }
            _ => self.power(),
        }
    }
    fn power(&mut self) -> Result<Expr, ParseError> {
        let base = self.atom()?;
        if let Some(Tok::Op('^')) = self.peek() {
            self.pos += 1;
            let neg = if let Some(Tok::Op('-')) = self.peek() {
                self.pos += 1;
                true
            } else {
                false
            };
            match self.peek() {
                Some(Tok::Num(v)) if v.fract() == 0.0 && v.abs() < 64.0 => {
                    let e = *v as i32;
                    self.pos += 1;
                    Ok(Expr::Pow(Box::new(base), if neg { -e } else { e }))
                }
                _ => self.err("expected an integer exponent after '^'"),
            }
        } else {
            Ok(base)
        }
    }
    fn atom(&mut self) -> Result<Expr, ParseError> {
        match self.peek().cloned() {
            Some(Tok::Num(v)) => {
                self.pos += 1;
                Ok(Expr::Num(v))
            }
            Some(Tok::Ident(name)) => {
                self.pos += 1;
                if let Some(Tok::Op('(')) = self.peek() {
                    let f = match name.as_str() {
                        "sin" => Func::Sin,
                        "cos" => Func::Cos,
                        "sqrt" => Func::Sqrt,
                        _ => {
                            return Err(ParseError {
                                at: self.toks[self.pos - 1].0,
                                message: format!(
                                    "unknown function '{name}' (expected sin, cos or sqrt)"
                                ),
                            })
                        }
                    };
                    self.pos += 1;
                    let arg = self.expr()?;
                    if self.peek() != Some(&Tok::Op(')')) {
                        return self.err("expected ')'");
                    }
                    self.pos += 1;
                    Ok(Expr::Fun(f, Box::new(arg)))
                } else {
                    Ok(Expr::Sym(name))
                }
            }
            Some(Tok::Op('(')) => {
                self.pos += 1;
                let e = self.expr()?;
                if self.peek() != Some(&Tok::Op(')')) {
                    return self.err("expected ')'");
                }
                self.pos += 1;
                Ok(e)
            }
            Some(Tok::Op(c)) => {
                self.err(format!("expected a number, a name or '(' but found '{c}'"))
            }
            None => self.err("expression ends too early"),
        }
    }
}

impl Expr {
    /// Parse an expression.
    ///
    /// # Errors
    /// [`ParseError`] with the character position for an empty or malformed expression.
    pub fn parse(text: &str) -> Result<Expr, ParseError> {
        let toks = tokenize(text)?;
        if toks.is_empty() {
            return Err(ParseError {
                at: 0,
                message: "empty expression".into(),
            });
        }
        // The parser recurses once per parenthesis and per prefix sign: bound both, so a
        // hostile file gets an error, not a stack overflow.
        let (mut depth, mut signs) = (0usize, 0usize);
        for (at, t) in &toks {
            match t {
                Tok::Op('(') => depth += 1,
                Tok::Op(')') => depth = depth.saturating_sub(1),
                _ => {}
            }
            signs = match t {
                Tok::Op('-' | '+') => signs + 1,
                _ => 0,
            };
            if depth > MAX_NESTING || signs > MAX_NESTING {
                return Err(ParseError {
                    at: *at,
                    message: format!(
                        "nested deeper than {MAX_NESTING} (parentheses or signs in a row)"
                    ),
                });
            }
        }
        let mut p = Parser {
            toks: &toks,
            pos: 0,
            len: text.len(),
        };
        let e = p.expr()?;
        if p.pos != toks.len() {
            return p.err("unexpected text after the end of the expression");
        }
        Ok(e)
    }

    /// All identifiers used (excluding `pi`), in order of first appearance.
    pub fn symbols(&self) -> Vec<String> {
        let mut out = Vec::new();
        self.visit_symbols(&mut |s| {
            if s != "pi" && !out.iter().any(|o: &String| o == s) {
                out.push(s.to_string());
            }
        });
        out
    }

    fn visit_symbols(&self, f: &mut dyn FnMut(&str)) {
        match self {
            Expr::Num(_) => {}
            Expr::Sym(s) => f(s),
            Expr::Add(a, b) | Expr::Sub(a, b) | Expr::Mul(a, b) | Expr::Div(a, b) => {
                a.visit_symbols(f);
                b.visit_symbols(f);
            }
            Expr::Pow(a, _) | Expr::Neg(a) | Expr::Fun(_, a) => a.visit_symbols(f),
        }
    }

    /// Numeric value with the given symbol values (`pi` is built in).
    ///
    /// Returns `None` when a symbol has no value.
    pub fn eval(&self, values: &BTreeMap<String, f64>) -> Option<f64> {
        Some(match self {
            Expr::Num(v) => *v,
            Expr::Sym(s) if s == "pi" => std::f64::consts::PI,
            Expr::Sym(s) => *values.get(s)?,
            Expr::Add(a, b) => a.eval(values)? + b.eval(values)?,
            Expr::Sub(a, b) => a.eval(values)? - b.eval(values)?,
            Expr::Mul(a, b) => a.eval(values)? * b.eval(values)?,
            Expr::Div(a, b) => a.eval(values)? / b.eval(values)?,
            Expr::Pow(a, e) => a.eval(values)?.powi(*e),
            Expr::Neg(a) => -a.eval(values)?,
            Expr::Fun(Func::Sin, a) => a.eval(values)?.sin(),
            Expr::Fun(Func::Cos, a) => a.eval(values)?.cos(),
            Expr::Fun(Func::Sqrt, a) => a.eval(values)?.sqrt(),
        })
    }

    /// Write `self` as `Σ n_k·q_k + θ0` where `q_k` are the given joint variables with
    /// integer coefficients `n_k` and `θ0` is a number (constants substituted).
    ///
    /// This is the form a rotation angle must have (DH θ or α, `rot_*` transforms), so that
    /// its sine and cosine expand exactly by the angle-addition formulas.
    ///
    /// # Errors
    /// A message when the angle is not of that form (non-integer or symbolic coefficient,
    /// product of joints, a joint inside a function, an unknown symbol).
    pub fn linear_angle(
        &self,
        joints: &[String],
        constants: &BTreeMap<String, f64>,
    ) -> Result<(Vec<i64>, f64), String> {
        let (c, k) = self.linear(joints, constants, "an angle")?;
        let mut ints = Vec::with_capacity(c.len());
        for (j, x) in c.iter().enumerate() {
            if (x - x.round()).abs() > 1e-12 {
                return Err(format!(
                    "joint '{}' has the non-integer coefficient {x} in an angle",
                    joints[j]
                ));
            }
            ints.push(x.round() as i64);
        }
        Ok((ints, k))
    }

    /// Write `self` as `Σ c_k·q_k + x0` with real coefficients `c_k` and a number `x0`
    /// (constants substituted): the form of a translation (DH d or a, `trans` entries), so
    /// that a prismatic joint's velocity is `Σ c_k q̇_k`. `what` names the quantity in errors
    /// ("an angle", "a translation").
    ///
    /// # Errors
    /// A message when the expression is not of that form.
    pub fn linear(
        &self,
        joints: &[String],
        constants: &BTreeMap<String, f64>,
        what: &str,
    ) -> Result<(Vec<f64>, f64), String> {
        // Each sub-expression becomes (coefficients as f64, constant).
        fn go(
            e: &Expr,
            joints: &[String],
            constants: &BTreeMap<String, f64>,
            what: &str,
        ) -> Result<(Vec<f64>, f64), String> {
            let n = joints.len();
            let is_const = |c: &Vec<f64>| c.iter().all(|&x| x == 0.0);
            Ok(match e {
                Expr::Num(v) => (vec![0.0; n], *v),
                Expr::Sym(s) if s == "pi" => (vec![0.0; n], std::f64::consts::PI),
                Expr::Sym(s) => {
                    if let Some(k) = joints.iter().position(|j| j == s) {
                        let mut c = vec![0.0; n];
                        c[k] = 1.0;
                        (c, 0.0)
                    } else if let Some(v) = constants.get(s) {
                        (vec![0.0; n], *v)
                    } else {
                        return Err(format!(
                            "'{s}' in {what} must be a joint variable or a numeric constant"
                        ));
                    }
                }
                Expr::Add(a, b) | Expr::Sub(a, b) => {
                    let (ca, ka) = go(a, joints, constants, what)?;
                    let (cb, kb) = go(b, joints, constants, what)?;
                    let sgn = if matches!(e, Expr::Sub(..)) {
                        -1.0
                    } else {
                        1.0
                    };
                    (
                        ca.iter().zip(&cb).map(|(x, y)| x + sgn * y).collect(),
                        ka + sgn * kb,
                    )
                }
                Expr::Neg(a) => {
                    let (c, k) = go(a, joints, constants, what)?;
                    (c.iter().map(|x| -x).collect(), -k)
                }
                Expr::Mul(a, b) => {
                    let (ca, ka) = go(a, joints, constants, what)?;
                    let (cb, kb) = go(b, joints, constants, what)?;
                    if is_const(&ca) {
                        (cb.iter().map(|x| x * ka).collect(), ka * kb)
                    } else if is_const(&cb) {
                        (ca.iter().map(|x| x * kb).collect(), ka * kb)
                    } else {
                        return Err(format!("{what} may not multiply two joint variables"));
                    }
                }
                Expr::Div(a, b) => {
                    let (ca, ka) = go(a, joints, constants, what)?;
                    let (cb, kb) = go(b, joints, constants, what)?;
                    if !is_const(&cb) {
                        return Err(format!("{what} may not divide by a joint variable"));
                    }
                    (ca.iter().map(|x| x / kb).collect(), ka / kb)
                }
                Expr::Pow(..) | Expr::Fun(..) => {
                    let (c, k) = match e {
                        Expr::Pow(a, p) => {
                            let (c, k) = go(a, joints, constants, what)?;
                            (c, k.powi(*p))
                        }
                        Expr::Fun(f, a) => {
                            let (c, k) = go(a, joints, constants, what)?;
                            let v = match f {
                                Func::Sin => k.sin(),
                                Func::Cos => k.cos(),
                                Func::Sqrt => k.sqrt(),
                            };
                            (c, v)
                        }
                        _ => unreachable!(),
                    };
                    if !is_const(&c) {
                        return Err(format!(
                            "a joint variable in {what} may appear only linearly (no powers or functions of it)"
                        ));
                    }
                    (c, k)
                }
            })
        }
        go(self, joints, constants, what)
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expr::Num(v) => write!(f, "{v}"),
            Expr::Sym(s) => write!(f, "{s}"),
            Expr::Add(a, b) => write!(f, "({a} + {b})"),
            Expr::Sub(a, b) => write!(f, "({a} - {b})"),
            Expr::Mul(a, b) => write!(f, "({a}*{b})"),
            Expr::Div(a, b) => write!(f, "({a}/{b})"),
            Expr::Pow(a, e) => write!(f, "({a})^{e}"),
            Expr::Neg(a) => write!(f, "(-{a})"),
            Expr::Fun(func, a) => {
                let name = match func {
                    Func::Sin => "sin",
                    Func::Cos => "cos",
                    Func::Sqrt => "sqrt",
                };
                write!(f, "{name}({a})")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_precedence_and_evaluates() {
        let e = Expr::parse("-L5 - L6 + 2*3^2/4").unwrap();
        let mut v = BTreeMap::new();
        v.insert("L5".to_string(), 0.1);
        v.insert("L6".to_string(), 0.1);
        assert!((e.eval(&v).unwrap() - (-0.2 + 4.5)).abs() < 1e-15);
        assert_eq!(e.symbols(), vec!["L5", "L6"]);
    }

    #[test]
    fn linear_angle_of_coupled_joint() {
        let joints: Vec<String> = (0..6).map(|i| format!("q{i}")).collect();
        let e = Expr::parse("-q2 - pi/2").unwrap();
        let (c, k) = e.linear_angle(&joints, &BTreeMap::new()).unwrap();
        assert_eq!(c, vec![0, 0, -1, 0, 0, 0]);
        assert!((k + std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!(Expr::parse("q1*q2")
            .unwrap()
            .linear_angle(&joints, &BTreeMap::new())
            .is_err());
        assert!(Expr::parse("q1/2")
            .unwrap()
            .linear_angle(&joints, &BTreeMap::new())
            .is_err());
    }

    #[test]
    fn malformed_expressions_report_position() {
        let e = Expr::parse("q0 + * 2").unwrap_err();
        assert_eq!(e.at, 5);
        assert!(Expr::parse("(q0").unwrap_err().message.contains("')'"));
        assert!(Expr::parse("q0 $").unwrap_err().message.contains("'$'"));
        assert!(Expr::parse("tan(q0)").unwrap_err().message.contains("tan"));
        assert!(Expr::parse("").is_err());
    }
}
