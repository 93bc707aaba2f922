//! Symbols and exact trigonometry of the symbolic model (Symbolica atoms).
//!
//! Variables: for each joint k that appears in a rotation, `S{k} = sin q_k`, `C{k} = cos q_k`;
//! for each joint in a translation, `Q{k} = q_k`; velocities `QD{k}`, accelerations `QDD{k}`;
//! barycentric parameters `P{j}`. The sine and cosine of an angle `Σ n_k q_k + θ0` are exact
//! polynomials in S_k, C_k (angle addition, reduced modulo `S_k² + C_k² = 1`).

use crate::expr::{Expr, Func};
use crate::model::Model;
use symbolica::atom::{Atom, AtomCore, Symbol};
use symbolica::{parse, symbol};

/// Joint symbols of one model's symbolic work (one set per joint; a kernel uses those it
/// needs: S, C for joints in angles, Q for joints in translations).
#[derive(Clone, Default)]
pub struct Vars {
    /// `S{k}` = sin q_k.
    pub s: Vec<Symbol>,
    /// `C{k}` = cos q_k.
    pub c: Vec<Symbol>,
    /// `Q{k}` = q_k.
    pub q: Vec<Symbol>,
    /// `QD{k}` = q̇_k.
    pub qd: Vec<Symbol>,
    /// `QDD{k}` = q̈_k.
    pub qdd: Vec<Symbol>,
}

impl Vars {
    /// Symbols for the model's joints.
    pub fn new(model: &Model) -> Vars {
        let n = model.joints.len();
        let mk = |p: &str| {
            (0..n)
                .map(|k| symbol!(&format!("lockstep::{p}{k}")))
                .collect()
        };
        Vars {
            s: mk("S"),
            c: mk("C"),
            q: mk("Q"),
            qd: mk("QD"),
            qdd: mk("QDD"),
        }
    }
}

/// Expand and reduce modulo `S_k² + C_k² = 1` until no power of an `S_k` above one is left.
pub fn reduce(e: &Atom, v: &Vars) -> Atom {
    let mut cur = e.expand();
    for k in 0..v.s.len() {
        let sk = v.s[k].get_name().to_string();
        let ck = v.c[k].get_name().to_string();
        let pat = parse!(&format!("{sk}^n_"));
        let rhs = parse!(&format!("{sk}^(n_-2)*(1-{ck}^2)"));
        loop {
            if !cur.contains_symbol(v.s[k]) {
                break;
            }
            let next = cur
                .replace(pat.to_pattern())
                .when(symbol!("n_").filter(|n| n >= 2))
                .with(rhs.to_pattern())
                .expand();
            if next == cur {
                break;
            }
            cur = next;
        }
    }
    cur
}

/// The best rational approximation of a finite f64 with relative error below 1e-15 and a
/// denominator below 10¹², or the exact binary fraction when there is none.
pub fn rational(x: f64) -> Atom {
    if x == 0.0 {
        return Atom::num(0);
    }
    if x.fract() == 0.0 && x.abs() < 9e15 {
        return Atom::num(x as i64);
    }
    // Continued fraction.
    let (mut h0, mut h1, mut k0, mut k1) = (0i128, 1i128, 1i128, 0i128);
    let mut r = x.abs();
    for _ in 0..40 {
        let a = r.floor();
        if a > 1e15 {
            break;
        }
        let ai = a as i128;
        let (h2, k2) = (ai * h1 + h0, ai * k1 + k0);
        if k2 > 1_000_000_000_000 {
            break;
        }
        (h0, h1, k0, k1) = (h1, h2, k1, k2);
        let approx = h1 as f64 / k1 as f64;
        if (approx - x.abs()).abs() <= 1e-15 * x.abs() {
            let sign = if x < 0.0 { -1 } else { 1 };
            return Atom::num((sign * h1 as i64, k1 as i64));
        }
        let f = r - a;
        if f == 0.0 {
            break;
        }
        r = 1.0 / f;
    }
    // Exact dyadic fraction.
    let (mant, exp) = {
        let bits = x.abs().to_bits();
        let e = ((bits >> 52) & 0x7ff) as i32;
        let m = if e == 0 {
            (bits & ((1 << 52) - 1)) << 1
        } else {
            (bits & ((1 << 52) - 1)) | (1 << 52)
        };
        (m as i64, e - 1075)
    };
    let sign = if x < 0.0 { -1 } else { 1 };
    let num = Atom::num(sign * mant);
    if exp >= 0 {
        num * Atom::num(2).pow(Atom::num(exp as i64))
    } else {
        num / Atom::num(2).pow(Atom::num(-exp as i64))
    }
}

/// sin and cos of `n·q_k`, exact polynomials in S_k, C_k.
fn sincos_multiple(v: &Vars, k: usize, n: i64) -> (Atom, Atom) {
    let s = Atom::var(v.s[k]);
    let c = Atom::var(v.c[k]);
    let m = n.unsigned_abs();
    let (mut sn, mut cn) = (Atom::num(0), Atom::num(1));
    for _ in 0..m {
        let s2 = &sn * &c + &cn * &s;
        let c2 = &cn * &c - &sn * &s;
        sn = s2;
        cn = c2;
    }
    if n < 0 {
        sn = -sn;
    }
    (reduce(&sn, v), reduce(&cn, v))
}

/// sin and cos of a number, snapped to exact 0, ±1, ±1/2 where the angle is a multiple of
/// π/6 (so that π/2 offsets cancel exactly; ±√3/2 to f64 precision).
fn sincos_const(a: f64) -> (Atom, Atom) {
    let unit = std::f64::consts::PI / 6.0;
    let m = a / unit;
    if (m - m.round()).abs() < 1e-12 {
        let i = (m.round() as i64).rem_euclid(12);
        // sin(i·30°) for i = 0..11 in halves, and sqrt(3)/2 where needed.
        let table: [(i64, bool); 12] = [
            (0, false),
            (1, false),
            (1, true),
            (2, false),
            (1, true),
            (1, false),
            (0, false),
            (-1, false),
            (-1, true),
            (-2, false),
            (-1, true),
            (-1, false),
        ];
        let val = |(h, r3): (i64, bool)| -> Atom {
            if r3 {
                // √3/2 as a number: a symbolic root would reach the evaluator as a power.
                rational(h as f64 * 3f64.sqrt() / 2.0)
            } else {
                Atom::num((h, 2))
            }
        };
        let s = val(table[i as usize]);
        let c = val(table[((i + 3) % 12) as usize]);
        return (s, c);
    }
    (rational(a.sin()), rational(a.cos()))
}

/// sin and cos of `Σ n_k q_k + θ0` by the angle-addition formulas.
pub fn sincos(v: &Vars, joints: &[i64], offset: f64) -> (Atom, Atom) {
    let (mut s, mut c) = sincos_const(offset);
    for (k, &n) in joints.iter().enumerate() {
        if n == 0 {
            continue;
        }
        let (sk, ck) = sincos_multiple(v, k, n);
        let s2 = &s * &ck + &c * &sk;
        let c2 = &c * &ck - &s * &sk;
        s = s2;
        c = c2;
    }
    (reduce(&s, v), reduce(&c, v))
}

/// A model expression as an atom: joints become `Q{k}`, constants their (rational) values,
/// inertial symbols `lockstep::u_<name>`.
pub fn atom_of(e: &Expr, model: &Model, v: &Vars) -> Atom {
    match e {
        Expr::Num(x) => rational(*x),
        Expr::Sym(s) if s == "pi" => rational(std::f64::consts::PI),
        Expr::Sym(s) => {
            if let Some(k) = model.joints.iter().position(|j| j == s) {
                Atom::var(v.q[k])
            } else if let Some(x) = model.constants.get(s) {
                rational(*x)
            } else {
                Atom::var(user_symbol(s))
            }
        }
        Expr::Add(a, b) => atom_of(a, model, v) + atom_of(b, model, v),
        Expr::Sub(a, b) => atom_of(a, model, v) - atom_of(b, model, v),
        Expr::Mul(a, b) => atom_of(a, model, v) * atom_of(b, model, v),
        Expr::Div(a, b) => atom_of(a, model, v) / atom_of(b, model, v),
        Expr::Pow(a, n) => atom_of(a, model, v).pow(Atom::num(*n as i64)),
        Expr::Neg(a) => -atom_of(a, model, v),
        Expr::Fun(f, a) => {
            let x = atom_of(a, model, v);
            match f {
                Func::Sin => x.sin(),
                Func::Cos => x.cos(),
                Func::Sqrt => x.sqrt(),
            }
        }
    }
}

/// The Symbolica symbol of a model-file inertial symbol.
pub fn user_symbol(name: &str) -> Symbol {
    symbol!(&format!("lockstep::u_{name}"))
}

/// The barycentric parameters of the model: name, link, kind (0..10) and the expression in
/// the model file's inertial symbols. Structurally zero ones are left out.
pub struct Barycentric {
    /// Parameter name (`M`-symbol or `M_<link>`, `MX_<link>`, `XX_<link>` …).
    pub name: String,
    /// Link index.
    pub link: usize,
    /// Kind index into `[M, MX, MY, MZ, XX, XY, XZ, YY, YZ, ZZ]`.
    pub kind: usize,
    /// Value in terms of the model file's symbols (parallel-axis theorem applied).
    pub expr: Atom,
}

/// Barycentric parameters of every link (m, m·c, I about the frame origin).
pub fn barycentric(model: &Model, v: &Vars) -> Vec<Barycentric> {
    const KINDS: [&str; 10] = ["M", "MX", "MY", "MZ", "XX", "XY", "XZ", "YY", "YZ", "ZZ"];
    let mut out = Vec::new();
    for (li, l) in model.links.iter().enumerate() {
        let m = atom_of(&l.mass, model, v);
        let c: Vec<Atom> = l.com.iter().map(|e| atom_of(e, model, v)).collect();
        let i: Vec<Atom> = l.inertia.iter().map(|e| atom_of(e, model, v)).collect();
        let (x, y, z) = (&c[0], &c[1], &c[2]);
        let exprs = [
            m.clone(),
            &m * x,
            &m * y,
            &m * z,
            &i[0] + &m * (y * y + z * z),
            &i[1] - &m * x * y,
            &i[2] - &m * x * z,
            &i[3] + &m * (x * x + z * z),
            &i[4] - &m * y * z,
            &i[5] + &m * (x * x + y * y),
        ];
        for (kind, e) in exprs.into_iter().enumerate() {
            let e = e.expand();
            if e.is_zero() {
                continue;
            }
            let name = if kind == 0 {
                match &l.mass {
                    Expr::Sym(s) if !model.constants.contains_key(s) => s.clone(),
                    _ => format!("M_{}", l.name),
                }
            } else {
                format!("{}_{}", KINDS[kind], l.name)
            };
            out.push(Barycentric {
                name,
                link: li,
                kind,
                expr: e,
            });
        }
    }
    out
}
