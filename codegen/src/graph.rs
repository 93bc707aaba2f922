//! Customised symbolic computation (Khalil & Kleinfinger, 1987; the method behind SYMORO):
//! every non-trivial quantity of a recursive algorithm becomes a named intermediate `T{n}`
//! whose definition is a small Symbolica expression in earlier intermediates and the inputs.
//!
//! - Symbolica normalises and expands each definition, so products with zero vanish,
//!   `x − x` cancels and constant rotations by ±π/2 become permutations without operations.
//! - Identical definitions are shared (hash-consing, also up to sign and a numeric factor):
//!   common subexpressions across kernels and passes cost nothing twice.
//! - Derivatives (∂/∂q_k, ∂/∂q̇_k, ∂/∂p_j, d/dt) are taken in forward mode through the graph, one
//!   intermediate at a time, with structural zeros skipped by dependency sets.
//! - Emission walks only what an output needs, in creation order (a topological order): one
//!   `let` per intermediate, branch-free and allocation-free.

use crate::emit::{lit, Ops};
use crate::symbolic::Vars;
use proc_macro2::{Ident, Span, TokenStream};
use quote::quote;
use std::collections::HashMap;
use symbolica::atom::{Atom, AtomCore, AtomView, Symbol};
use symbolica::coefficient::CoefficientView;
use symbolica::domains::float::RealLike;
use symbolica::symbol;

/// The input symbols of a graph and how they differentiate.
#[derive(Clone, Default)]
pub struct Inputs {
    /// Joint symbols S, C, Q, QD, QDD.
    pub vars: Vars,
    /// `P{j}`: barycentric inertial parameters.
    pub p: Vec<Symbol>,
    /// Joints that move (q̇ ≠ 0) in this graph's configuration, for d/dt.
    pub free: Vec<usize>,
}

/// A direction of differentiation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// ∂/∂q_k.
    Joint(usize),
    /// ∂/∂q̇_k (q, q̈ held).
    Velocity(usize),
    /// ∂/∂p_j.
    Param(usize),
    /// d/dt along the free joints' velocities and accelerations.
    Time,
}

/// A small fixed-width bit set over the input symbols.
#[derive(Clone, Default, PartialEq, Eq)]
struct Bits(Vec<u64>);

impl Bits {
    fn set(&mut self, i: usize) {
        if self.0.len() <= i / 64 {
            self.0.resize(i / 64 + 1, 0);
        }
        self.0[i / 64] |= 1 << (i % 64);
    }
    fn union(&mut self, o: &Bits) {
        if self.0.len() < o.0.len() {
            self.0.resize(o.0.len(), 0);
        }
        for (a, b) in self.0.iter_mut().zip(&o.0) {
            *a |= b;
        }
    }
    fn meets(&self, o: &Bits) -> bool {
        self.0.iter().zip(&o.0).any(|(a, b)| a & b != 0)
    }
}

/// A graph of named intermediates.
pub struct Graph {
    /// The inputs.
    pub inputs: Inputs,
    defs: Vec<Atom>,
    syms: Vec<Symbol>,
    ids: HashMap<Symbol, usize>,
    index: HashMap<Atom, usize>,
    deps: Vec<Bits>,
    refs: Vec<Vec<usize>>,
    base: HashMap<Symbol, usize>,
    memo: HashMap<(usize, Direction), Atom>,
    prefix: String,
}

fn coeff_f64(c: &CoefficientView) -> f64 {
    match c {
        CoefficientView::Natural(n, d, _, _) => *n as f64 / *d as f64,
        other => other
            .to_float(64)
            .map(|x| x.re.to_f64())
            .unwrap_or(f64::NAN),
    }
}

/// `(numeric coefficient, rest)` of a product; `None` when there is no coefficient.
fn split_coefficient(e: &Atom) -> Option<(Atom, Atom)> {
    if let AtomView::Mul(m) = e.as_view() {
        if m.has_coefficient() {
            let c = m.get_coefficient()?.to_owned();
            let rest = e / &c;
            return Some((c, rest));
        }
    }
    None
}

/// A number, an input or intermediate, or a number times one.
fn is_simple(e: &Atom) -> bool {
    match e.as_view() {
        AtomView::Num(_) | AtomView::Var(_) => true,
        AtomView::Mul(m) => {
            m.get_nargs() == 2
                && m.has_coefficient()
                && m.iter().any(|f| matches!(f, AtomView::Var(_)))
        }
        _ => false,
    }
}

impl Graph {
    /// An empty graph over `inputs`; intermediates are named `{prefix}T{n}`.
    pub fn new(inputs: Inputs, prefix: &str) -> Graph {
        let mut base = HashMap::new();
        let v = &inputs.vars;
        let all = [&v.s, &v.c, &v.q, &v.qd, &v.qdd, &inputs.p];
        for v in all {
            for &s in v {
                let n = base.len();
                base.insert(s, n);
            }
        }
        Graph {
            inputs,
            defs: Vec::new(),
            syms: Vec::new(),
            ids: HashMap::new(),
            index: HashMap::new(),
            deps: Vec::new(),
            refs: Vec::new(),
            base,
            memo: HashMap::new(),
            prefix: prefix.to_string(),
        }
    }

    /// Input dependencies and referenced intermediates of an expression.
    fn deps_of(&self, e: &Atom) -> (Bits, Vec<usize>) {
        let mut b = Bits::default();
        let mut refs = Vec::new();
        for s in e.get_all_symbols(false) {
            if let Some(&n) = self.ids.get(&s) {
                b.union(&self.deps[n]);
                refs.push(n);
            } else if let Some(&i) = self.base.get(&s) {
                b.set(i);
            }
        }
        refs.sort_unstable();
        (b, refs)
    }

    /// Normalise `e` (expand) and return it when it is simple (a number, a symbol, or a
    /// number times a symbol); otherwise the intermediate that holds it, created on first
    /// use and shared by every later identical definition (up to sign and numeric factor).
    pub fn value(&mut self, e: Atom) -> Atom {
        let e = e.expand();
        if is_simple(&e) {
            return e;
        }
        if let Some((c, rest)) = split_coefficient(&e) {
            if !is_simple(&rest) {
                let t = self.value(rest);
                return c * t;
            }
        }
        if let Some(&n) = self.index.get(&e) {
            return Atom::var(self.syms[n]);
        }
        let neg = -&e;
        if let Some(&n) = self.index.get(&neg) {
            return -Atom::var(self.syms[n]);
        }
        let n = self.defs.len();
        let sym = symbol!(&format!("lockstep::{}T{n}", self.prefix));
        let (deps, refs) = self.deps_of(&e);
        self.ids.insert(sym, n);
        self.refs.push(refs);
        self.index.insert(e.clone(), n);
        self.defs.push(e);
        self.syms.push(sym);
        self.deps.push(deps);
        Atom::var(sym)
    }

    /// [`Graph::value`] of each entry.
    pub fn values<const N: usize>(&mut self, v: [Atom; N]) -> [Atom; N] {
        v.map(|e| self.value(e))
    }

    fn direction_bits(&self, dir: Direction) -> Bits {
        let mut b = Bits::default();
        let (i, v) = (&self.inputs, &self.inputs.vars);
        let mut add = |s: Symbol| {
            if let Some(&k) = self.base.get(&s) {
                b.set(k);
            }
        };
        match dir {
            Direction::Joint(k) => {
                add(v.s[k]);
                add(v.c[k]);
                add(v.q[k]);
            }
            Direction::Velocity(k) => add(v.qd[k]),
            Direction::Param(j) => add(i.p[j]),
            Direction::Time => {
                for &k in &i.free {
                    add(v.s[k]);
                    add(v.c[k]);
                    add(v.q[k]);
                    add(v.qd[k]);
                }
            }
        }
        b
    }

    /// Derivative of an input symbol.
    fn input_derivative(&self, s: Symbol, dir: Direction) -> Atom {
        let (i, v) = (&self.inputs, &self.inputs.vars);
        let zero = Atom::num(0);
        let Some(k) = (0..v.s.len())
            .find(|&k| s == v.s[k] || s == v.c[k] || s == v.q[k] || s == v.qd[k] || s == v.qdd[k])
        else {
            return match dir {
                Direction::Param(j) if s == i.p[j] => Atom::num(1),
                _ => zero,
            };
        };
        let rate = match dir {
            Direction::Velocity(j) if j == k && s == v.qd[k] => return Atom::num(1),
            Direction::Joint(j) if j == k => Atom::num(1),
            Direction::Time if i.free.contains(&k) => {
                if s == v.qd[k] {
                    return Atom::var(v.qdd[k]);
                }
                Atom::var(v.qd[k])
            }
            _ => return zero,
        };
        if s == v.s[k] {
            Atom::var(v.c[k]) * rate
        } else if s == v.c[k] {
            -Atom::var(v.s[k]) * rate
        } else if s == v.q[k] {
            rate
        } else {
            zero
        }
    }

    fn shallow_derivative(&mut self, e: &Atom, dir: Direction) -> Atom {
        let mut acc = Atom::num(0);
        let mut syms: Vec<Symbol> = e.get_all_symbols(false).into_iter().collect();
        syms.sort_by_key(|s| s.get_name().to_string());
        for s in syms {
            let ds = match self.ids.get(&s) {
                Some(&n) => match self.memo.get(&(n, dir)) {
                    Some(d) => d.clone(),
                    None => continue,
                },
                None => self.input_derivative(s, dir),
            };
            if ds.is_zero() {
                continue;
            }
            acc += e.derivative(s) * ds;
        }
        self.value(acc)
    }

    /// Derivative of `e` in direction `dir`, as a value of the graph.
    pub fn derivative(&mut self, e: &Atom, dir: Direction) -> Atom {
        let mask = self.direction_bits(dir);
        // Intermediates below `e` that depend on the direction and are not yet differentiated.
        let mut todo = Vec::new();
        let mut stack: Vec<usize> = Vec::new();
        let mut seen = std::collections::HashSet::new();
        let push = |n: usize,
                    stack: &mut Vec<usize>,
                    seen: &mut std::collections::HashSet<usize>| {
            if self.deps[n].meets(&mask) && !self.memo.contains_key(&(n, dir)) && seen.insert(n) {
                stack.push(n);
            }
        };
        for n in self.deps_of(e).1 {
            push(n, &mut stack, &mut seen);
        }
        while let Some(n) = stack.pop() {
            todo.push(n);
            for &r in &self.refs[n] {
                push(r, &mut stack, &mut seen);
            }
        }
        todo.sort_unstable();
        for n in todo {
            let def = self.defs[n].clone();
            let d = self.shallow_derivative(&def, dir);
            self.memo.insert((n, dir), d);
        }
        self.shallow_derivative(e, dir)
    }

    /// Evaluate `outputs` numerically with the given input values (intermediates computed
    /// from their definitions). Inputs without a value count as zero.
    pub fn evaluate(&self, outputs: &[Atom], inputs: &HashMap<Symbol, f64>) -> Vec<f64> {
        let needed = self.needed(outputs);
        let mut vals: HashMap<Symbol, f64> = inputs.clone();
        for n in needed {
            let v = eval_view(self.defs[n].as_view(), &vals);
            vals.insert(self.syms[n], v);
        }
        outputs
            .iter()
            .map(|o| eval_view(o.as_view(), &vals))
            .collect()
    }

    /// Intermediates that `outputs` need, in creation order.
    fn needed(&self, outputs: &[Atom]) -> Vec<usize> {
        let mut seen = vec![false; self.defs.len()];
        let mut stack: Vec<usize> = Vec::new();
        let mut mark = |n: usize, stack: &mut Vec<usize>| {
            if !seen[n] {
                seen[n] = true;
                stack.push(n);
            }
        };
        for o in outputs {
            for n in self.deps_of(o).1 {
                mark(n, &mut stack);
            }
        }
        while let Some(n) = stack.pop() {
            for &r in &self.refs[n] {
                mark(r, &mut stack);
            }
        }
        (0..self.defs.len()).filter(|&n| seen[n]).collect()
    }

    /// Input symbols used by `outputs` (directly or through intermediates).
    pub fn inputs_used(&self, outputs: &[Atom]) -> std::collections::HashSet<Symbol> {
        let mut used = std::collections::HashSet::new();
        let mut add = |e: &Atom| {
            for s in e.get_all_symbols(false) {
                if !self.ids.contains_key(&s) {
                    used.insert(s);
                }
            }
        };
        for o in outputs {
            add(o);
        }
        for n in self.needed(outputs) {
            add(&self.defs[n]);
        }
        used
    }

    /// Straight-line Rust computing `outputs`: the statements (one `let` per intermediate
    /// needed), one expression per output, and the operation count. `name` spells each
    /// input symbol in Rust.
    ///
    /// # Panics
    /// When an input symbol has no spelling (a generator bug, not a user error).
    pub fn emit(
        &self,
        outputs: &[Atom],
        name: &dyn Fn(Symbol) -> Option<TokenStream>,
    ) -> (Vec<TokenStream>, Vec<TokenStream>, Ops) {
        let (needed, local) = self.numbered(outputs);
        let spell = |s: Symbol| self.spell(&local, name, s);
        let mut ops = Ops::default();
        let mut stmts = Vec::new();
        for &n in &needed {
            let id = local_name(&local, n);
            let e = print(self.defs[n].as_view(), &spell, &mut ops);
            stmts.push(quote!(let #id = #e;));
        }
        let results = outputs
            .iter()
            .map(|o| print(o.as_view(), &spell, &mut ops))
            .collect();
        (stmts, results, ops)
    }
}

/// The Rust name of intermediate `n` in a function's numbering `local`.
fn local_name(local: &HashMap<usize, usize>, n: usize) -> Ident {
    Ident::new(&format!("t{}", local[&n]), Span::call_site())
}

impl Graph {
    /// The intermediates `outputs` need, in creation order, and their numbering within one
    /// function (t0, t1, …).
    fn numbered(&self, outputs: &[Atom]) -> (Vec<usize>, HashMap<usize, usize>) {
        let needed = self.needed(outputs);
        let local = needed.iter().enumerate().map(|(i, &n)| (n, i)).collect();
        (needed, local)
    }

    /// Symbol `s` in Rust: an intermediate by its number in `local`, an input by `name`.
    fn spell(
        &self,
        local: &HashMap<usize, usize>,
        name: &dyn Fn(Symbol) -> Option<TokenStream>,
        s: Symbol,
    ) -> TokenStream {
        if let Some(&n) = self.ids.get(&s) {
            let id = local_name(local, n);
            quote!(#id)
        } else {
            name(s).unwrap_or_else(|| panic!("no Rust spelling for input {s}"))
        }
    }
}

/// [`Graph::emit_hoisted`]'s two bodies.
pub struct Hoisted {
    /// The statements of the intermediates that do not depend on a varying input, in order.
    pub invariant: Vec<TokenStream>,
    /// The invariant intermediates the varying part reads (their names), in order.
    pub frontier: Vec<TokenStream>,
    /// The varying part: one `let` per frontier intermediate from `inv[i]`, then one per
    /// intermediate that depends on a varying input.
    pub varying: Vec<TokenStream>,
    /// One expression per output (in the varying part's names).
    pub results: Vec<TokenStream>,
    /// The input symbols the invariant statements read.
    pub invariant_inputs: std::collections::HashSet<Symbol>,
    /// The input symbols the varying statements and the outputs read.
    pub varying_inputs: std::collections::HashSet<Symbol>,
}

impl Graph {
    /// [`Graph::emit`] split for loop-invariant code motion: the intermediates that depend
    /// only on inputs `varies` rejects (a locked joint's trigonometry, the parameters p) are
    /// computed once by the first body, which returns those the rest reads (the frontier);
    /// the second body reads them from `inv` and computes only what depends on a varying
    /// input. Each intermediate's expression is printed as in [`Graph::emit`], so the
    /// values are the same bits.
    ///
    /// # Panics
    /// When an input symbol has no spelling (a generator bug, not a user error).
    pub fn emit_hoisted(
        &self,
        outputs: &[Atom],
        name: &dyn Fn(Symbol) -> Option<TokenStream>,
        varies: &dyn Fn(Symbol) -> bool,
    ) -> Hoisted {
        let (needed, local) = self.numbered(outputs);
        let mut varying_bits = Bits::default();
        for (&s, &i) in &self.base {
            if varies(s) {
                varying_bits.set(i);
            }
        }
        let varying: Vec<bool> = needed
            .iter()
            .map(|&n| self.deps[n].meets(&varying_bits))
            .collect();
        // The frontier: invariant intermediates read by a varying one or by an output.
        let mut read = vec![false; needed.len()];
        for (i, &n) in needed.iter().enumerate() {
            if varying[i] {
                for &r in &self.refs[n] {
                    read[local[&r]] = true;
                }
            }
        }
        for o in outputs {
            for r in self.deps_of(o).1 {
                read[local[&r]] = true;
            }
        }
        let spell = |s: Symbol| self.spell(&local, name, s);
        let mut ops = Ops::default();
        let mut out = Hoisted {
            invariant: Vec::new(),
            frontier: Vec::new(),
            varying: Vec::new(),
            results: Vec::new(),
            invariant_inputs: Default::default(),
            varying_inputs: Default::default(),
        };
        let inputs_of = |e: &Atom| {
            e.get_all_symbols(false)
                .into_iter()
                .filter(|s| !self.ids.contains_key(s))
                .collect::<Vec<_>>()
        };
        for o in outputs {
            out.varying_inputs.extend(inputs_of(o));
        }
        for (i, &n) in needed.iter().enumerate() {
            let id = local_name(&local, n);
            let e = print(self.defs[n].as_view(), &spell, &mut ops);
            let inputs = inputs_of(&self.defs[n]);
            if varying[i] {
                out.varying_inputs.extend(inputs);
                out.varying.push(quote!(let #id = #e;));
            } else {
                out.invariant_inputs.extend(inputs);
                out.invariant.push(quote!(let #id = #e;));
                if read[i] {
                    let k = proc_macro2::Literal::usize_unsuffixed(out.frontier.len());
                    out.varying
                        .insert(out.frontier.len(), quote!(let #id = inv[#k];));
                    out.frontier.push(quote!(#id));
                }
            }
        }
        out.results = outputs
            .iter()
            .map(|o| print(o.as_view(), &spell, &mut ops))
            .collect();
        out
    }
}

fn eval_view(v: AtomView, vals: &HashMap<Symbol, f64>) -> f64 {
    match v {
        AtomView::Num(n) => coeff_f64(&n.get_coeff_view()),
        AtomView::Var(x) => vals.get(&x.get_symbol()).copied().unwrap_or(0.0),
        AtomView::Add(a) => a.iter().map(|t| eval_view(t, vals)).sum(),
        AtomView::Mul(m) => m.iter().map(|t| eval_view(t, vals)).product(),
        AtomView::Pow(p) => {
            let (b, e) = p.get_base_exp();
            eval_view(b, vals).powf(eval_view(e, vals))
        }
        AtomView::Fun(f) => {
            let x = f.iter().next().map(|a| eval_view(a, vals)).unwrap_or(0.0);
            match f.get_symbol().get_name() {
                n if n.ends_with("sin") => x.sin(),
                n if n.ends_with("cos") => x.cos(),
                n if n.ends_with("sqrt") => x.sqrt(),
                _ => f64::NAN,
            }
        }
    }
}

/// A term's sign and magnitude: `(true, |t|)` for a term with a negative coefficient.
fn print_signed(
    v: AtomView,
    spell: &dyn Fn(Symbol) -> TokenStream,
    ops: &mut Ops,
) -> (bool, TokenStream) {
    match v {
        AtomView::Num(n) => {
            let x = coeff_f64(&n.get_coeff_view());
            (x < 0.0, lit(x.abs()))
        }
        AtomView::Mul(m) => {
            let mut neg = false;
            let mut factors: Vec<TokenStream> = Vec::new();
            let mut count = 0usize;
            for f in m.iter() {
                match f {
                    AtomView::Num(n) => {
                        let x = coeff_f64(&n.get_coeff_view());
                        neg ^= x < 0.0;
                        if x.abs() != 1.0 {
                            factors.insert(0, lit(x.abs()));
                            count += 1;
                        }
                    }
                    AtomView::Pow(p) => {
                        let (b, e) = p.get_base_exp();
                        let (t, k) = power(b, e, spell, ops);
                        factors.push(t);
                        count += k;
                    }
                    other => {
                        factors.push(print_factor(other, spell, ops));
                        count += 1;
                    }
                }
            }
            ops.mul += count.saturating_sub(1);
            let first = factors.first().cloned().unwrap_or_else(|| quote!(1.0));
            let rest = &factors[1.min(factors.len())..];
            (neg, quote!(#first #(* #rest)*))
        }
        AtomView::Pow(p) => {
            let (b, e) = p.get_base_exp();
            let (t, k) = power(b, e, spell, ops);
            ops.mul += k.saturating_sub(1);
            (false, t)
        }
        other => (false, print_factor(other, spell, ops)),
    }
}

/// `b^e` as Rust and the number of factors it stands for (for the multiplication count).
fn power(
    b: AtomView,
    e: AtomView,
    spell: &dyn Fn(Symbol) -> TokenStream,
    ops: &mut Ops,
) -> (TokenStream, usize) {
    let b = print_factor(b, spell, ops);
    let k = match e {
        AtomView::Num(n) => coeff_f64(&n.get_coeff_view()),
        _ => f64::NAN,
    };
    if k == 2.0 {
        (quote!(#b * #b), 2)
    } else if k == 3.0 {
        (quote!(#b * #b * #b), 3)
    } else if k == -1.0 {
        ops.other += 1;
        (quote!((1.0 / #b)), 1)
    } else if k == 0.5 {
        ops.other += 1;
        (quote!(#b.sqrt()), 1)
    } else {
        ops.other += 1;
        let k = proc_macro2::Literal::i32_unsuffixed(k as i32);
        (quote!(#b.powi(#k)), 1)
    }
}

/// An operand that binds tighter than `*` (parenthesised when it is a sum or a product).
fn print_factor(v: AtomView, spell: &dyn Fn(Symbol) -> TokenStream, ops: &mut Ops) -> TokenStream {
    match v {
        AtomView::Var(x) => spell(x.get_symbol()),
        AtomView::Num(_) | AtomView::Add(_) | AtomView::Mul(_) => {
            let t = print(v, spell, ops);
            quote!((#t))
        }
        AtomView::Pow(p) => {
            let (b, e) = p.get_base_exp();
            let (t, k) = power(b, e, spell, ops);
            ops.mul += k.saturating_sub(1);
            quote!((#t))
        }
        AtomView::Fun(f) => {
            let a = f
                .iter()
                .next()
                .map(|a| print_factor(a, spell, ops))
                .unwrap_or_else(|| quote!(0.0));
            ops.other += 1;
            match f.get_symbol().get_name() {
                n if n.ends_with("sin") => quote!(#a.sin()),
                n if n.ends_with("cos") => quote!(#a.cos()),
                _ => quote!(#a.sqrt()),
            }
        }
    }
}

/// Rust for an expression; sums print negative terms as subtractions.
fn print(v: AtomView, spell: &dyn Fn(Symbol) -> TokenStream, ops: &mut Ops) -> TokenStream {
    match v {
        AtomView::Add(a) => {
            let terms: Vec<(bool, TokenStream)> =
                a.iter().map(|t| print_signed(t, spell, ops)).collect();
            ops.add += terms.len().saturating_sub(1);
            // Lead with a positive term when there is one.
            let lead = terms.iter().position(|(n, _)| !n).unwrap_or(0);
            let (n0, t0) = &terms[lead];
            let mut out = if *n0 { quote!(-#t0) } else { quote!(#t0) };
            for (i, (n, t)) in terms.iter().enumerate() {
                if i == lead {
                    continue;
                }
                out = if *n {
                    quote!(#out - #t)
                } else {
                    quote!(#out + #t)
                };
            }
            out
        }
        _ => {
            let (neg, t) = print_signed(v, spell, ops);
            if neg {
                quote!(-(#t))
            } else {
                t
            }
        }
    }
}
