//! User-defined effects: a torque term written as an expression of the joints' states and
//! of its own named parameters, parsed and checked when the plant is read and evaluated
//! without a rebuild (issue 54 item 1).
//!
//! ```text
//! K3*(q_q3 - qeq3)^3               cubic stiffness about qeq3
//! A*sin(6*q_q2 + phi)              cogging, six periods per turn
//! c*qd_q1*abs(qd_q1)               quadratic (aerodynamic) drag
//! Fm*tanh((qd_q5 + qd_q6)/0.01)    friction of a motor that drives the sum of two joints
//! ```
//!
//! Symbols, for the model's joint named J ([`crate::names`]): `q_J` position (rad or m),
//! `qd_J` velocity, `qdd_J` acceleration (the simulator takes an effect linear in them into
//! the inertia matrix, [`Expression::acceleration_coefficients`]), `tau_J` commanded torque
//! (N·m or N), `z_J` LuGre bristle deflection (simulator only; 0 without LuGre); the form
//! of earlier versions, numbered from 0 (`q2`, `qd2`, … for the model's third joint), is
//! still read;
//! `t` the time (s; the records' time column); the constant `pi`; any other name must be one of the expression's declared parameters.
//! Operators `+ - * / ^` (`^` binds tighter than unary minus: `-x^2 = -(x^2)`), functions
//! `sin cos tan exp ln sqrt abs sign tanh atan sinh cosh` of one argument and `min max` of
//! two. `sign(0) = 0`, the Coulomb convention of [`crate::effects::sign`].
//!
//! The expression is the torque the effect takes from the joint, as the catalogue's
//! built-ins: τ_i = [D q̈ + C q̇ + φ]_i + Σ effects_i (a spring `Ks*(q3 - qeq3)` written by
//! hand is the built-in spring). Its derivatives with respect to its parameters and to the
//! states are symbolic ([`Expression::derivative`]), so a fit's Jacobian and a regressor
//! column are exact.
//!
//! Why not a crate: the well-kept evaluators measured (exmex 0.21) have no derivative of
//! `abs` or `signum`, give `signum(0) = 1` and report a syntax error without its column;
//! the three are what a friction or drag term needs and what a user needs to fix a typo
//! (docs/src/design/expression-effects.md).

use std::fmt;

/// What a symbol of an expression stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Symbol {
    /// Position of joint k (rad or m).
    Q(usize),
    /// Velocity of joint k.
    Qd(usize),
    /// Acceleration of joint k.
    Qdd(usize),
    /// Commanded torque of joint k (N·m or N), before gain and input couplings.
    Tau(usize),
    /// LuGre bristle deflection of joint k.
    Z(usize),
    /// Declared parameter number i of the expression.
    Param(usize),
    /// Time (s): the records' time column (the simulation's time, the time of an IDIM or
    /// equation-error row): a drift, a warm-up.
    T,
}

/// One-argument functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Func {
    Sin,
    Cos,
    Tan,
    Exp,
    Ln,
    Sqrt,
    Abs,
    Sign,
    Tanh,
    Atan,
    Sinh,
    Cosh,
}

impl Func {
    const ALL: [(&'static str, Func); 12] = [
        ("sin", Func::Sin),
        ("cos", Func::Cos),
        ("tan", Func::Tan),
        ("exp", Func::Exp),
        ("ln", Func::Ln),
        ("sqrt", Func::Sqrt),
        ("abs", Func::Abs),
        ("sign", Func::Sign),
        ("tanh", Func::Tanh),
        ("atan", Func::Atan),
        ("sinh", Func::Sinh),
        ("cosh", Func::Cosh),
    ];

    fn name(self) -> &'static str {
        Func::ALL.iter().find(|x| x.1 == self).map_or("?", |x| x.0)
    }

    fn apply(self, x: f64) -> f64 {
        match self {
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::Tan => x.tan(),
            Func::Exp => x.exp(),
            Func::Ln => x.ln(),
            Func::Sqrt => x.sqrt(),
            Func::Abs => x.abs(),
            Func::Sign => crate::effects::sign(x),
            Func::Tanh => x.tanh(),
            Func::Atan => x.atan(),
            Func::Sinh => x.sinh(),
            Func::Cosh => x.cosh(),
        }
    }
}

/// Binary operators and two-argument functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Min,
    Max,
}

impl Op {
    fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            Op::Add => a + b,
            Op::Sub => a - b,
            Op::Mul => a * b,
            Op::Div => a / b,
            Op::Pow => {
                if b == b.round() && b.abs() <= 16.0 {
                    a.powi(b as i32)
                } else {
                    a.powf(b)
                }
            }
            Op::Min => a.min(b),
            Op::Max => a.max(b),
        }
    }
}

/// An expression tree.
#[derive(Debug, Clone, PartialEq)]
pub enum Node {
    /// A number.
    Num(f64),
    /// A state variable or parameter.
    Var(Symbol),
    /// −x.
    Neg(Box<Node>),
    /// A function of one argument.
    Call(Func, Box<Node>),
    /// A binary operation or a function of two arguments.
    Bin(Op, Box<Node>, Box<Node>),
}

/// A parse or check error, with the column (1-based, in characters) where it was found.
#[derive(Debug, Clone, PartialEq)]
pub struct ExpressionError {
    /// Column of the offending character or name (1-based).
    pub column: usize,
    /// What is wrong and what was expected.
    pub message: String,
}

impl fmt::Display for ExpressionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "column {}: {}", self.column, self.message)
    }
}

impl std::error::Error for ExpressionError {}

/// A parsed and checked expression of a model's states and declared parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Expression {
    /// The text as written.
    pub text: String,
    /// The declared parameter names (Symbol::Param(i) is `parameters[i]`).
    pub parameters: Vec<String>,
    /// The tree.
    pub root: Node,
    /// Parameters that occur in a denominator, with the column of the division.
    pub divisors: Vec<(usize, usize)>,
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Num(f64),
    Ident(String),
    Sym(char),
}

fn tokens(text: &str) -> Result<Vec<(Token, usize)>, ExpressionError> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let col = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit()
            || (c == '.' && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit()))
        {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                i += 1;
            }
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut k = i + 1;
                if k < chars.len() && (chars[k] == '+' || chars[k] == '-') {
                    k += 1;
                }
                if k < chars.len() && chars[k].is_ascii_digit() {
                    i = k;
                    while i < chars.len() && chars[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let s: String = chars[start..i].iter().collect();
            let v: f64 = s.parse().map_err(|_| ExpressionError {
                column: col,
                message: format!("'{s}' is not a number"),
            })?;
            out.push((Token::Num(v), col));
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push((Token::Ident(chars[start..i].iter().collect()), col));
        } else if "+-*/^(),".contains(c) {
            out.push((Token::Sym(c), col));
            i += 1;
        } else {
            return Err(ExpressionError {
                column: col,
                message: format!(
                    "unexpected character '{c}' (expected a number, a name, an operator + - * / ^, or parentheses)"
                ),
            });
        }
    }
    Ok(out)
}

/// The state-variable symbol a name stands for: by the joint's name (`q_q3`, `qd_q3`,
/// `qdd_q3`, `tau_q3`, `z_q3`) or numbered from 0 as in earlier versions (`q2`, `qd2`, …),
/// the index unchecked ([`crate::names::state_variable`]).
fn state_symbol(joints: &[&str], name: &str) -> Option<Symbol> {
    let (signal, k) = crate::names::state_variable(joints, name)?;
    Some(match signal {
        "qdd" => Symbol::Qdd(k),
        "qd" => Symbol::Qd(k),
        "q" => Symbol::Q(k),
        "tau" => Symbol::Tau(k),
        _ => Symbol::Z(k),
    })
}

struct Parser<'a> {
    toks: Vec<(Token, usize)>,
    at: usize,
    end: usize,
    joints: &'a [&'a str],
    parameters: &'a [String],
    used: Vec<bool>,
    divisors: Vec<(usize, usize)>,
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Token> {
        self.toks.get(self.at).map(|t| &t.0)
    }

    fn column(&self) -> usize {
        self.toks.get(self.at).map_or(self.end, |t| t.1)
    }

    fn error<T>(&self, message: String) -> Result<T, ExpressionError> {
        Err(ExpressionError {
            column: self.column(),
            message,
        })
    }

    fn expect(&mut self, c: char) -> Result<(), ExpressionError> {
        if self.peek() == Some(&Token::Sym(c)) {
            self.at += 1;
            Ok(())
        } else {
            let found = match self.peek() {
                None => "the end".to_string(),
                Some(Token::Num(v)) => format!("'{v}'"),
                Some(Token::Ident(s)) => format!("'{s}'"),
                Some(Token::Sym(s)) => format!("'{s}'"),
            };
            self.error(format!("expected '{c}', found {found}"))
        }
    }

    fn sum(&mut self) -> Result<Node, ExpressionError> {
        let mut left = self.product()?;
        while let Some(Token::Sym(c @ ('+' | '-'))) = self.peek() {
            let op = if *c == '+' { Op::Add } else { Op::Sub };
            self.at += 1;
            let right = self.product()?;
            left = Node::Bin(op, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn product(&mut self) -> Result<Node, ExpressionError> {
        let mut left = self.unary()?;
        while let Some(Token::Sym(c @ ('*' | '/'))) = self.peek() {
            let op = if *c == '*' { Op::Mul } else { Op::Div };
            let col = self.column();
            self.at += 1;
            let right = self.unary()?;
            if op == Op::Div {
                let mut ps = Vec::new();
                params_of(&right, &mut ps);
                self.divisors.extend(ps.into_iter().map(|p| (p, col)));
            }
            left = Node::Bin(op, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn unary(&mut self) -> Result<Node, ExpressionError> {
        match self.peek() {
            Some(Token::Sym('-')) => {
                self.at += 1;
                Ok(Node::Neg(Box::new(self.unary()?)))
            }
            Some(Token::Sym('+')) => {
                self.at += 1;
                self.unary()
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<Node, ExpressionError> {
        let base = self.atom()?;
        if self.peek() == Some(&Token::Sym('^')) {
            self.at += 1;
            let exponent = self.unary()?;
            return Ok(Node::Bin(Op::Pow, Box::new(base), Box::new(exponent)));
        }
        Ok(base)
    }

    fn atom(&mut self) -> Result<Node, ExpressionError> {
        let col = self.column();
        match self.peek().cloned() {
            Some(Token::Num(v)) => {
                self.at += 1;
                Ok(Node::Num(v))
            }
            Some(Token::Sym('(')) => {
                self.at += 1;
                let e = self.sum()?;
                self.expect(')')?;
                Ok(e)
            }
            Some(Token::Ident(name)) => {
                self.at += 1;
                if self.peek() == Some(&Token::Sym('(')) {
                    self.at += 1;
                    let mut args = vec![self.sum()?];
                    while self.peek() == Some(&Token::Sym(',')) {
                        self.at += 1;
                        args.push(self.sum()?);
                    }
                    self.expect(')')?;
                    let arity_error = |n: usize| ExpressionError {
                        column: col,
                        message: format!(
                            "'{name}' takes {n} argument{}, found {}",
                            if n == 1 { "" } else { "s" },
                            args.len()
                        ),
                    };
                    if let Some((_, f)) = Func::ALL.iter().find(|x| x.0 == name) {
                        if args.len() != 1 {
                            return Err(arity_error(1));
                        }
                        return Ok(Node::Call(*f, Box::new(args.remove(0))));
                    }
                    let op = match name.as_str() {
                        "min" => Op::Min,
                        "max" => Op::Max,
                        _ => {
                            return Err(ExpressionError {
                                column: col,
                                message: format!(
                                    "unknown function '{name}' (known: {}, min, max)",
                                    Func::ALL.map(|x| x.0).join(", ")
                                ),
                            })
                        }
                    };
                    if args.len() != 2 {
                        return Err(arity_error(2));
                    }
                    let b = args.pop().unwrap_or(Node::Num(0.0));
                    let a = args.pop().unwrap_or(Node::Num(0.0));
                    return Ok(Node::Bin(op, Box::new(a), Box::new(b)));
                }
                if name == "pi" {
                    return Ok(Node::Num(std::f64::consts::PI));
                }
                if name == "t" {
                    return Ok(Node::Var(Symbol::T));
                }
                if let Some(i) = self.parameters.iter().position(|p| *p == name) {
                    self.used[i] = true;
                    return Ok(Node::Var(Symbol::Param(i)));
                }
                if let Some(s) = state_symbol(self.joints, &name) {
                    let k = joint_of(s).unwrap_or(0);
                    if k >= self.joints.len() {
                        return Err(ExpressionError {
                            column: col,
                            message: format!(
                                "'{name}' numbers joint {k} (from 0), the model has {} joints ({}); write the joint by name, e.g. 'q_{}'",
                                self.joints.len(),
                                self.joints.join(", "),
                                self.joints.last().copied().unwrap_or("q1")
                            ),
                        });
                    }
                    return Ok(Node::Var(s));
                }
                Err(ExpressionError {
                    column: col,
                    message: format!(
                        "unknown symbol '{name}': not a state variable (q_J, qd_J, qdd_J, tau_J, z_J for a joint J of {}; t, the time) nor a declared parameter ({})",
                        self.joints.join(", "),
                        if self.parameters.is_empty() {
                            "none declared".to_string()
                        } else {
                            self.parameters.join(", ")
                        }
                    ),
                })
            }
            Some(Token::Sym(c)) => {
                self.error(format!("expected a number, a name or '(', found '{c}'"))
            }
            None => self.error("expected a number, a name or '(', found the end".into()),
        }
    }
}

fn joint_of(s: Symbol) -> Option<usize> {
    match s {
        Symbol::Q(k) | Symbol::Qd(k) | Symbol::Qdd(k) | Symbol::Tau(k) | Symbol::Z(k) => Some(k),
        Symbol::Param(_) | Symbol::T => None,
    }
}

fn params_of(n: &Node, out: &mut Vec<usize>) {
    match n {
        Node::Var(Symbol::Param(i)) if !out.contains(i) => out.push(*i),
        Node::Neg(a) | Node::Call(_, a) => params_of(a, out),
        Node::Bin(_, a, b) => {
            params_of(a, out);
            params_of(b, out);
        }
        _ => {}
    }
}

fn symbols_of(n: &Node, out: &mut Vec<Symbol>) {
    match n {
        Node::Var(s) if !out.contains(s) => out.push(*s),
        Node::Neg(a) | Node::Call(_, a) => symbols_of(a, out),
        Node::Bin(_, a, b) => {
            symbols_of(a, out);
            symbols_of(b, out);
        }
        _ => {}
    }
}

/// True when `name` reads as a state variable of a model with joints `joints` (`q_q3`,
/// `qd0`, …), a function or a constant: it cannot name a parameter.
pub fn is_reserved(joints: &[&str], name: &str) -> bool {
    state_symbol(joints, name).is_some()
        || name == "pi"
        || name == "t"
        || name == "min"
        || name == "max"
        || Func::ALL.iter().any(|x| x.0 == name)
}

impl Expression {
    /// Parse `text` for a model whose joints are named `joints` with the declared
    /// `parameters`.
    ///
    /// # Errors
    /// A syntax error, an unknown symbol or function, a function with the wrong number of
    /// arguments, a joint index beyond the model, a declared parameter that is reserved (a
    /// state-variable or function name), declared twice or not used; each with its column
    /// (a declaration error has column 0).
    pub fn parse(
        text: &str,
        joints: &[&str],
        parameters: &[String],
    ) -> Result<Expression, ExpressionError> {
        for (i, p) in parameters.iter().enumerate() {
            let bad = |message: String| Err(ExpressionError { column: 0, message });
            if p.is_empty()
                || !p
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_alphabetic() || c == '_')
                || !p.chars().all(|c| c.is_alphanumeric() || c == '_')
            {
                return bad(format!("parameter '{p}': expected a name (a letter or '_', then letters, digits or '_')"));
            }
            if is_reserved(joints, p) {
                return bad(format!(
                    "parameter '{p}': the name is a state variable, function or constant"
                ));
            }
            if parameters[..i].contains(p) {
                return bad(format!("parameter '{p}' is declared twice"));
            }
        }
        let toks = tokens(text)?;
        if toks.is_empty() {
            return Err(ExpressionError {
                column: 1,
                message: "empty expression".into(),
            });
        }
        let mut p = Parser {
            end: text.chars().count() + 1,
            toks,
            at: 0,
            joints,
            parameters,
            used: vec![false; parameters.len()],
            divisors: Vec::new(),
        };
        let root = p.sum()?;
        if p.at < p.toks.len() {
            return p.error("expected an operator or the end".into());
        }
        if let Some(i) = p.used.iter().position(|u| !u) {
            return Err(ExpressionError {
                column: 0,
                message: format!("parameter '{}' is declared but not used", parameters[i]),
            });
        }
        Ok(Expression {
            text: text.to_string(),
            parameters: parameters.to_vec(),
            root,
            divisors: p.divisors,
        })
    }

    /// Every symbol the expression reads, each once.
    pub fn symbols(&self) -> Vec<Symbol> {
        let mut v = Vec::new();
        symbols_of(&self.root, &mut v);
        v
    }

    /// ∂/∂`s` of the expression as a tree (simplified where a factor is 0 or 1); `abs' =
    /// sign`, `sign' = 0`, `min`/`max` by the side that is taken.
    pub fn derivative(&self, s: Symbol) -> Node {
        diff(&self.root, s)
    }

    /// The coefficients of the accelerations the expression reads, ∂u/∂q̈_k per joint k it
    /// reads q̈ of, as trees. An expression linear in the accelerations is u = u₀(q, q̇, τ,
    /// z) plus Σ_k a_k(q, q̇, τ, z) q̈_k, and the simulator takes the sum into the inertia
    /// matrix: an inertia the effect adds, an armature `Ia*qdd3`, a coupled motor
    /// `Jm*(qdd4 + qdd5)`.
    ///
    /// # Errors
    /// A coefficient that reads an acceleration itself (not linear in them), named.
    pub fn acceleration_coefficients(&self) -> Result<Vec<(usize, Node)>, String> {
        let mut out = Vec::new();
        for s in self.symbols() {
            let Symbol::Qdd(k) = s else { continue };
            let d = self.derivative(s);
            let mut read = Vec::new();
            symbols_of(&d, &mut read);
            if let Some(Symbol::Qdd(m)) = read.iter().find(|x| matches!(x, Symbol::Qdd(_))) {
                return Err(format!(
                    "the torque is not linear in the accelerations (its coefficient of qdd{k} reads qdd{m}); the simulator takes an effect's accelerations into the inertia matrix, which needs u = u0 + sum of a_k qdd_k"
                ));
            }
            out.push((k, d));
        }
        Ok(out)
    }

    /// True when the expression is linear in its parameters (each derivative with respect
    /// to a parameter reads no parameter): then it has regressor columns.
    pub fn is_linear_in_parameters(&self) -> bool {
        (0..self.parameters.len()).all(|i| {
            let mut ps = Vec::new();
            params_of(&self.derivative(Symbol::Param(i)), &mut ps);
            ps.is_empty()
        })
    }
}

fn num(v: f64) -> Node {
    Node::Num(v)
}

fn add(a: Node, b: Node) -> Node {
    match (&a, &b) {
        (Node::Num(x), _) if *x == 0.0 => b,
        (_, Node::Num(y)) if *y == 0.0 => a,
        (Node::Num(x), Node::Num(y)) => num(x + y),
        _ => Node::Bin(Op::Add, Box::new(a), Box::new(b)),
    }
}

fn sub(a: Node, b: Node) -> Node {
    match (&a, &b) {
        (_, Node::Num(y)) if *y == 0.0 => a,
        (Node::Num(x), _) if *x == 0.0 => neg(b),
        _ => Node::Bin(Op::Sub, Box::new(a), Box::new(b)),
    }
}

fn neg(a: Node) -> Node {
    match a {
        Node::Num(x) => num(-x),
        Node::Neg(x) => *x,
        _ => Node::Neg(Box::new(a)),
    }
}

fn mul(a: Node, b: Node) -> Node {
    match (&a, &b) {
        (Node::Num(x), _) | (_, Node::Num(x)) if *x == 0.0 => num(0.0),
        (Node::Num(x), _) if *x == 1.0 => b,
        (_, Node::Num(y)) if *y == 1.0 => a,
        (Node::Num(x), Node::Num(y)) => num(x * y),
        _ => Node::Bin(Op::Mul, Box::new(a), Box::new(b)),
    }
}

fn div(a: Node, b: Node) -> Node {
    match (&a, &b) {
        (Node::Num(x), _) if *x == 0.0 => num(0.0),
        (_, Node::Num(y)) if *y == 1.0 => a,
        _ => Node::Bin(Op::Div, Box::new(a), Box::new(b)),
    }
}

fn call(f: Func, a: Node) -> Node {
    Node::Call(f, Box::new(a))
}

fn bin(op: Op, a: &Node, b: &Node) -> Node {
    Node::Bin(op, Box::new(a.clone()), Box::new(b.clone()))
}

fn reads(n: &Node, s: Symbol) -> bool {
    let mut v = Vec::new();
    symbols_of(n, &mut v);
    v.contains(&s)
}

fn diff(n: &Node, s: Symbol) -> Node {
    if !reads(n, s) {
        return num(0.0);
    }
    match n {
        Node::Num(_) => num(0.0),
        Node::Var(x) => num(if *x == s { 1.0 } else { 0.0 }),
        Node::Neg(a) => neg(diff(a, s)),
        Node::Call(f, a) => {
            let da = diff(a, s);
            let u = (**a).clone();
            let outer = match f {
                Func::Sin => call(Func::Cos, u),
                Func::Cos => neg(call(Func::Sin, u)),
                Func::Tan => div(
                    num(1.0),
                    Node::Bin(Op::Pow, Box::new(call(Func::Cos, u)), Box::new(num(2.0))),
                ),
                Func::Exp => call(Func::Exp, u),
                Func::Ln => div(num(1.0), u),
                Func::Sqrt => div(num(0.5), call(Func::Sqrt, u)),
                Func::Abs => call(Func::Sign, u),
                Func::Sign => num(0.0),
                Func::Tanh => sub(
                    num(1.0),
                    Node::Bin(Op::Pow, Box::new(call(Func::Tanh, u)), Box::new(num(2.0))),
                ),
                Func::Atan => div(
                    num(1.0),
                    add(
                        num(1.0),
                        Node::Bin(Op::Pow, Box::new(u), Box::new(num(2.0))),
                    ),
                ),
                Func::Sinh => call(Func::Cosh, u),
                Func::Cosh => call(Func::Sinh, u),
            };
            mul(outer, da)
        }
        Node::Bin(op, a, b) => {
            let (da, db) = (diff(a, s), diff(b, s));
            match op {
                Op::Add => add(da, db),
                Op::Sub => sub(da, db),
                Op::Mul => add(mul(da, (**b).clone()), mul((**a).clone(), db)),
                Op::Div => sub(
                    div(da, (**b).clone()),
                    div(
                        mul((**a).clone(), db),
                        Node::Bin(Op::Pow, b.clone(), Box::new(num(2.0))),
                    ),
                ),
                Op::Pow => {
                    if let Node::Num(k) = **b {
                        // d(u^k) = k u^(k−1) u'
                        let lower = if k == 2.0 {
                            (**a).clone()
                        } else {
                            Node::Bin(Op::Pow, a.clone(), Box::new(num(k - 1.0)))
                        };
                        mul(mul(num(k), lower), da)
                    } else {
                        // d(u^v) = u^v (v' ln u + v u'/u)
                        mul(
                            bin(Op::Pow, a, b),
                            add(
                                mul(db, call(Func::Ln, (**a).clone())),
                                div(mul((**b).clone(), da), (**a).clone()),
                            ),
                        )
                    }
                }
                Op::Min | Op::Max => {
                    // min(a, b)' = (a' + b')/2 − sign(a − b)(a' − b')/2; max with +.
                    let half_sum = div(add(da.clone(), db.clone()), num(2.0));
                    let half_diff = div(
                        mul(call(Func::Sign, bin(Op::Sub, a, b)), sub(da, db)),
                        num(2.0),
                    );
                    if *op == Op::Min {
                        sub(half_sum, half_diff)
                    } else {
                        add(half_sum, half_diff)
                    }
                }
            }
        }
    }
}

/// One instruction of a [`Program`]: a stack machine over f64.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Instr {
    Const(f64),
    Load(usize),
    Neg,
    Call(Func),
    Bin(Op),
}

/// Deepest stack a [`Program`] may need.
const STACK: usize = 64;

/// Most inputs (distinct state variables) a [`Program`] may read.
pub const INPUTS: usize = 32;

/// A tree compiled to a flat instruction list with its inputs numbered ([`Program::inputs`]),
/// constants folded: what the simulator's inner loop evaluates.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    code: Vec<Instr>,
    /// The symbols the program reads, in slot order: `eval(values)` takes their values.
    pub inputs: Vec<Symbol>,
    /// The stack depth the program needs (≤ [`STACK`]).
    depth: usize,
}

/// Stack depth of the evaluator's small frame ([`Program::eval_with`]): most expressions
/// fit, and a frame this size is cleared without a call to `memset`.
const SMALL_STACK: usize = 8;

impl Program {
    /// Compile `node`, replacing each symbol for which `fixed` gives a value by that
    /// constant (parameters, locked joints' positions) and folding constants.
    ///
    /// # Errors
    /// The expression needs a deeper stack than `STACK` (too deeply nested) or reads
    /// more than [`INPUTS`] state variables.
    pub fn compile(node: &Node, fixed: &dyn Fn(Symbol) -> Option<f64>) -> Result<Program, String> {
        let folded = fold(node, fixed);
        let mut p = Program {
            code: Vec::new(),
            inputs: Vec::new(),
            depth: 0,
        };
        let depth = p.emit(&folded);
        p.depth = depth;
        if depth > STACK {
            return Err(format!(
                "the expression nests too deeply (needs {depth} stack levels, at most {STACK})"
            ));
        }
        if p.inputs.len() > INPUTS {
            return Err(format!(
                "the expression reads {} state variables, at most {INPUTS}",
                p.inputs.len()
            ));
        }
        Ok(p)
    }

    /// Emit code for `n`; returns the stack depth it needs.
    fn emit(&mut self, n: &Node) -> usize {
        match n {
            Node::Num(v) => {
                self.code.push(Instr::Const(*v));
                1
            }
            Node::Var(s) => {
                let slot = match self.inputs.iter().position(|x| x == s) {
                    Some(i) => i,
                    None => {
                        self.inputs.push(*s);
                        self.inputs.len() - 1
                    }
                };
                self.code.push(Instr::Load(slot));
                1
            }
            Node::Neg(a) => {
                let d = self.emit(a);
                self.code.push(Instr::Neg);
                d
            }
            Node::Call(f, a) => {
                let d = self.emit(a);
                self.code.push(Instr::Call(*f));
                d
            }
            Node::Bin(op, a, b) => {
                let da = self.emit(a);
                let db = self.emit(b);
                self.code.push(Instr::Bin(*op));
                da.max(db + 1)
            }
        }
    }

    /// The value at `values` (one per [`Program::inputs`], same order).
    #[inline]
    pub fn eval(&self, values: &[f64]) -> f64 {
        self.eval_with(|i| values[i])
    }

    /// The value with input slot i's value given by `load(i)` (slots as in
    /// [`Program::inputs`]): the simulator's form, which reads the state in place.
    #[inline]
    pub fn eval_with(&self, load: impl Fn(usize) -> f64) -> f64 {
        if self.depth <= SMALL_STACK {
            self.run::<SMALL_STACK>(load)
        } else {
            self.run::<STACK>(load)
        }
    }

    #[inline]
    fn run<const N: usize>(&self, load: impl Fn(usize) -> f64) -> f64 {
        let mut stack = [0.0f64; N];
        let mut top = 0usize;
        for ins in &self.code {
            match *ins {
                Instr::Const(v) => {
                    stack[top] = v;
                    top += 1;
                }
                Instr::Load(i) => {
                    stack[top] = load(i);
                    top += 1;
                }
                Instr::Neg => stack[top - 1] = -stack[top - 1],
                Instr::Call(f) => stack[top - 1] = f.apply(stack[top - 1]),
                Instr::Bin(op) => {
                    top -= 1;
                    stack[top - 1] = op.apply(stack[top - 1], stack[top]);
                }
            }
        }
        stack[0]
    }

    /// The value with each input's value given by `at` (the symbol it stands for).
    pub fn eval_at(&self, at: impl Fn(Symbol) -> f64) -> f64 {
        self.eval_with(|i| at(self.inputs[i]))
    }

    /// True when the program is a constant (reads nothing).
    pub fn is_constant(&self) -> bool {
        self.inputs.is_empty()
    }
}

fn fold(n: &Node, fixed: &dyn Fn(Symbol) -> Option<f64>) -> Node {
    match n {
        Node::Num(v) => num(*v),
        Node::Var(s) => fixed(*s).map_or(Node::Var(*s), num),
        Node::Neg(a) => neg(fold(a, fixed)),
        Node::Call(f, a) => match fold(a, fixed) {
            Node::Num(v) => num(f.apply(v)),
            x => call(*f, x),
        },
        Node::Bin(op, a, b) => match (fold(a, fixed), fold(b, fixed)) {
            (Node::Num(x), Node::Num(y)) => num(op.apply(x, y)),
            (x, y) => match op {
                Op::Add => add(x, y),
                Op::Sub => sub(x, y),
                Op::Mul => mul(x, y),
                Op::Div => div(x, y),
                _ => Node::Bin(*op, Box::new(x), Box::new(y)),
            },
        },
    }
}

impl fmt::Display for Node {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Node::Num(v) => write!(f, "{v}"),
            Node::Var(s) => match s {
                Symbol::Q(k) => write!(f, "q{k}"),
                Symbol::Qd(k) => write!(f, "qd{k}"),
                Symbol::Qdd(k) => write!(f, "qdd{k}"),
                Symbol::Tau(k) => write!(f, "tau{k}"),
                Symbol::Z(k) => write!(f, "z{k}"),
                Symbol::Param(i) => write!(f, "p{i}"),
                Symbol::T => write!(f, "t"),
            },
            Node::Neg(a) => write!(f, "(-{a})"),
            Node::Call(g, a) => write!(f, "{}({a})", g.name()),
            Node::Bin(op, a, b) => match op {
                Op::Min => write!(f, "min({a}, {b})"),
                Op::Max => write!(f, "max({a}, {b})"),
                _ => {
                    let o = match op {
                        Op::Add => "+",
                        Op::Sub => "-",
                        Op::Mul => "*",
                        Op::Div => "/",
                        _ => "^",
                    };
                    write!(f, "({a} {o} {b})")
                }
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, params: &[&str]) -> Result<Expression, ExpressionError> {
        let p: Vec<String> = params.iter().map(|s| s.to_string()).collect();
        Expression::parse(text, &["q0", "q1", "q2", "q3", "q4", "q5"], &p)
    }

    fn value(e: &Expression, at: &dyn Fn(Symbol) -> f64) -> f64 {
        let prog = Program::compile(&e.root, &|_| None).unwrap();
        let vals: Vec<f64> = prog.inputs.iter().map(|s| at(*s)).collect();
        prog.eval(&vals)
    }

    /// Precedence and associativity as written in the module docs, against the same
    /// numbers computed by hand.
    #[test]
    fn precedence_and_functions_evaluate_as_written() {
        let at = |s: Symbol| match s {
            Symbol::Q(3) => 0.5,
            Symbol::Qd(1) => -2.0,
            Symbol::Param(0) => 3.0,
            Symbol::Param(1) => 0.1,
            _ => f64::NAN,
        };
        let e = parse("K3*(q3 - qeq)^3", &["K3", "qeq"]).unwrap();
        assert_eq!(value(&e, &at), 3.0 * 0.4f64.powi(3));
        let e = parse("-q3^2 + 2^3^2 / 64", &[]).unwrap();
        assert_eq!(value(&e, &at), -0.25 + 512.0 / 64.0);
        let e = parse(
            "K3*qd1*abs(qd1) + sign(0*q3) + min(q3, qeq) - max(1, 2)",
            &["K3", "qeq"],
        )
        .unwrap();
        assert_eq!(value(&e, &at), 3.0 * -2.0 * 2.0 + 0.0 + 0.1 - 2.0);
        let e = parse("1.5e-1*sin(6*q3 + pi/2)", &[]).unwrap();
        assert!((value(&e, &at) - 0.15 * (3.0 + std::f64::consts::FRAC_PI_2).sin()).abs() < 1e-15);
    }

    /// The symbolic derivatives against central differences of the value.
    #[test]
    fn derivatives_match_central_differences() {
        let texts = [
            "K3*(q3 - qeq)^3",
            "K3*tanh((qd1 + q3)/qeq)",
            "sqrt(K3*q3^2 + 1)*exp(-qeq*qd1) / (1 + q3^2)",
            "atan(K3*qd1) + ln(2 + sin(q3)) + cosh(qeq*q3) - sinh(K3) + tan(0.3*q3)",
            "max(K3*q3, qeq) + min(q3, qd1*K3) + abs(q3 - qeq)*qd1 + q3^qeq",
        ];
        let syms = [
            Symbol::Param(0),
            Symbol::Param(1),
            Symbol::Q(3),
            Symbol::Qd(1),
        ];
        let base = [1.3, 0.7, 0.45, -0.8];
        for t in texts {
            let e = parse(t, &["K3", "qeq"]).unwrap();
            for (i, s) in syms.iter().enumerate() {
                let f = |h: f64| {
                    let at = |x: Symbol| {
                        let k = syms.iter().position(|y| *y == x).unwrap();
                        base[k] + if k == i { h } else { 0.0 }
                    };
                    value(&e, &at)
                };
                let h = 1e-6;
                let numeric = (f(h) - f(-h)) / (2.0 * h);
                let d = Expression {
                    root: e.derivative(*s),
                    ..e.clone()
                };
                let at = |x: Symbol| base[syms.iter().position(|y| *y == x).unwrap()];
                let exact = value(&d, &at);
                assert!(
                    (exact - numeric).abs() < 1e-7 * (1.0 + numeric.abs()),
                    "{t}: d/d{s:?} = {exact}, central difference {numeric}"
                );
            }
        }
    }

    #[test]
    fn linearity_in_the_parameters_is_decided_from_the_derivatives() {
        assert!(parse(
            "A*sin(6*q2) + B*cos(6*q2) + c*qd1*abs(qd1)",
            &["A", "B", "c"]
        )
        .unwrap()
        .is_linear_in_parameters());
        assert!(!parse("K3*(q3 - qeq)^3", &["K3", "qeq"])
            .unwrap()
            .is_linear_in_parameters());
    }

    /// Each mistake is named with its column.
    #[test]
    fn mistakes_are_named_with_their_column() {
        let err = |t: &str, p: &[&str]| parse(t, p).unwrap_err().to_string();
        assert_eq!(
            err("K3*(q3 - 1", &["K3"]),
            "column 11: expected ')', found the end"
        );
        assert!(err("K3*q3 + K33", &["K3"]).starts_with("column 9: unknown symbol 'K33'"));
        assert!(err("K3*q9", &["K3"]).starts_with(
            "column 4: 'q9' numbers joint 9 (from 0), the model has 6 joints (q0, q1, q2, q3, q4, q5); write the joint by name, e.g. 'q_q5'"
        ));
        // By name: the joint must be the model's.
        assert!(err("K3*q_q9", &["K3"]).starts_with("column 4: unknown symbol 'q_q9'"));
        let named = parse("K3*(q_q3 - qd_q3) + qdd_q2 + tau_q1*z_q0", &["K3"]).unwrap();
        let numbered = parse("K3*(q3 - qd3) + qdd2 + tau1*z0", &["K3"]).unwrap();
        assert_eq!(named.root.to_string(), numbered.root.to_string());
        assert_eq!(
            err("K3*sin(q3, q2)", &["K3"]),
            "column 4: 'sin' takes 1 argument, found 2"
        );
        assert!(err("K3*sinc(q3)", &["K3"]).starts_with("column 4: unknown function 'sinc'"));
        assert_eq!(
            err("K3*q3 $ 2", &["K3"]).split(" (").next().unwrap(),
            "column 7: unexpected character '$'"
        );
        assert_eq!(
            err("K3 q3", &["K3"]),
            "column 4: expected an operator or the end"
        );
        assert_eq!(
            err("q3", &["K3"]),
            "column 0: parameter 'K3' is declared but not used"
        );
        assert!(err("q3*qd2", &["qd2"]).contains("state variable"));
        assert_eq!(
            parse("q3/vs + 1/(c*q2)", &["vs", "c"]).unwrap().divisors,
            vec![(0, 3), (1, 10)]
        );
    }
}
