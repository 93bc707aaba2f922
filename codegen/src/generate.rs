//! From a validated model to the Rust source of its kernels module.

use crate::dynamics::{config_dynamics, ConfigDynamics, Tree};
use crate::emit::{lit, EmitError, Ops};
use crate::graph::{Direction, Graph, Inputs};
use crate::model::{Configuration, Model};
use crate::symbolic::{self, user_symbol, Vars};
use proc_macro2::{Ident, Span, TokenStream};
use quote::quote;
use std::collections::HashMap;
use std::time::Instant;
use symbolica::atom::{Atom, Symbol};

/// The generator's version, written into every emitted header.
pub const GENERATOR_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Figures of one emitted configuration.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ConfigReport {
    /// Configuration name.
    pub name: String,
    /// Free joints (names).
    pub free: Vec<String>,
    /// Barycentric parameters that appear in its equations.
    pub params_present: Vec<String>,
    /// Operation counts per kernel.
    pub ops: Vec<(String, Ops)>,
    /// Wall time to generate it (s).
    pub seconds: f64,
}

/// The result of generating one model.
pub struct Generated {
    /// Module source (pretty-printed).
    pub source: String,
    /// Per-configuration figures.
    pub configs: Vec<ConfigReport>,
    /// Wall time of the symbolic model (frames, D, φ, derivatives) (s).
    pub model_seconds: f64,
}

fn id(s: &str) -> Ident {
    Ident::new(s, Span::call_site())
}

/// Everything symbolic about a model that configurations share.
pub struct SymbolicModel<'m> {
    /// The model.
    pub model: &'m Model,
    /// Its symbols.
    pub vars: Vars,
    /// The kinematic tree of elementary motions.
    pub tree: Tree,
    /// Barycentric parameters.
    pub params: Vec<symbolic::Barycentric>,
    /// `p_sym[j]`: the parameter's symbol `P{j}`.
    pub p_sym: Vec<Symbol>,
}

impl<'m> SymbolicModel<'m> {
    /// Symbols, tree and parameters of `model`.
    pub fn new(model: &'m Model) -> SymbolicModel<'m> {
        let vars = Vars::new(model);
        let tree = Tree::new(model);
        let params = symbolic::barycentric(model, &vars);
        let p_sym = (0..params.len())
            .map(|j| symbolica::symbol!(&format!("lockstep::P{j}")))
            .collect();
        SymbolicModel {
            model,
            vars,
            tree,
            params,
            p_sym,
        }
    }

    /// Rust spelling of an input symbol in a kernel of the configuration `free`.
    fn spelling(&self, free: &[usize], s: Symbol) -> Option<TokenStream> {
        let v = &self.vars;
        let lit = proc_macro2::Literal::usize_unsuffixed;
        for k in 0..self.model.joints.len() {
            if s == v.s[k] {
                let i = id(&format!("s{k}"));
                return Some(quote!(#i));
            }
            if s == v.c[k] {
                let i = id(&format!("c{k}"));
                return Some(quote!(#i));
            }
            if s == v.q[k] {
                let k = lit(k);
                return Some(quote!(q[#k]));
            }
        }
        for (a, &k) in free.iter().enumerate() {
            let a = lit(a);
            if s == v.qd[k] {
                return Some(quote!(qd[#a]));
            }
            if s == v.qdd[k] {
                return Some(quote!(qdd[#a]));
            }
        }
        let j = self.p_sym.iter().position(|&p| p == s)?;
        let j = lit(j);
        Some(quote!(p[#j]))
    }
}

/// The joints whose sine or cosine `outputs` use: (joint, sine used, cosine used).
fn trig_used(sm: &SymbolicModel, g: &Graph, outputs: &[Atom]) -> Vec<(usize, bool, bool)> {
    let v = &sm.vars;
    let used = g.inputs_used(outputs);
    (0..sm.model.joints.len())
        .map(|k| (k, used.contains(&v.s[k]), used.contains(&v.c[k])))
        .filter(|&(_, s, c)| s || c)
        .collect()
}

/// Joint k's entries of the trigonometric table: (sin q_k at 2k, cos q_k at 2k + 1).
fn trig_slots(k: usize) -> (proc_macro2::Literal, proc_macro2::Literal) {
    (
        proc_macro2::Literal::usize_unsuffixed(2 * k),
        proc_macro2::Literal::usize_unsuffixed(2 * k + 1),
    )
}

/// The trigonometric table a kernel's `_trig` form reads, filled from `q`:
/// `sc[2k] = sin q_k`, `sc[2k + 1] = cos q_k` for the joints in `used` (the others 0).
fn trig_table(used: &[(usize, bool, bool)]) -> Vec<TokenStream> {
    if used.is_empty() {
        return vec![quote!(let sc = [0.0; 2 * super::NJ];)];
    }
    let mut out = vec![quote!(let mut sc = [0.0; 2 * super::NJ];)];
    for &(k, used_s, used_c) in used {
        let kk = proc_macro2::Literal::usize_unsuffixed(k);
        let (is, ic) = trig_slots(k);
        if used_s && used_c {
            out.push(quote!((sc[#is], sc[#ic]) = q[#kk].sin_cos();));
        } else if used_s {
            out.push(quote!(sc[#is] = q[#kk].sin();));
        } else {
            out.push(quote!(sc[#ic] = q[#kk].cos();));
        }
    }
    out
}

/// `let s{k} = sc[2k]; let c{k} = sc[2k + 1];` for the joints in `used`.
fn trig_prelude(used: &[(usize, bool, bool)]) -> Vec<TokenStream> {
    let mut out = Vec::new();
    for &(k, used_s, used_c) in used {
        let (s, c) = (id(&format!("s{k}")), id(&format!("c{k}")));
        let (is, ic) = trig_slots(k);
        if used_s {
            out.push(quote!(let #s = sc[#is];));
        }
        if used_c {
            out.push(quote!(let #c = sc[#ic];));
        }
    }
    out
}

fn nested(results: &[TokenStream], rows: usize, cols: usize) -> TokenStream {
    let rows_ts: Vec<TokenStream> = (0..rows)
        .map(|r| {
            let row = &results[r * cols..(r + 1) * cols];
            quote!([#(#row),*])
        })
        .collect();
    quote!([#(#rows_ts),*])
}

/// Straight-line body computing `outputs`: trig prelude (reads of the table `sc`),
/// intermediates, results; `used` the joints whose trigonometry it reads.
struct Body {
    pre: Vec<TokenStream>,
    stmts: Vec<TokenStream>,
    results: Vec<TokenStream>,
    used: Vec<(usize, bool, bool)>,
    ops: Ops,
}

fn body(sm: &SymbolicModel, cd: &ConfigDynamics, free: &[usize], outputs: &[Atom]) -> Body {
    let g = &cd.graph;
    let (stmts, results, mut ops) = g.emit(outputs, &|s| sm.spelling(free, s));
    let used = trig_used(sm, g, outputs);
    // One sin_cos (or sin, or cos) per joint used, as the typed form computes them.
    ops.other += used.len();
    Body {
        pre: trig_prelude(&used),
        stmts,
        results,
        used,
        ops,
    }
}

/// A kernel's two forms: `name_trig(q, sc, rest…)`, the body reading the trigonometric
/// table `sc` (the simulator fills it once per stage, the locked joints' once per run),
/// and `name(q, rest…)`, which fills the table from `q` and calls it. `rest` the arguments
/// after `q` (declarations), `names` their names.
#[allow(clippy::too_many_arguments)]
fn two_forms(
    name: &str,
    doc: &str,
    rest: &TokenStream,
    names: &[&str],
    ret: &TokenStream,
    used: &[(usize, bool, bool)],
    pre: &[TokenStream],
    body: TokenStream,
) -> TokenStream {
    let f = id(name);
    let f_trig = id(&format!("{name}_trig"));
    let fill = trig_table(used);
    let names: Vec<proc_macro2::Ident> = names.iter().map(|n| id(n)).collect();
    let doc_trig = format!(
        "[`{name}`] with the joints' sines and cosines read from `sc` (`[f64; 2 NJ]`: \
         `sc[2k] = sin q_k`, `sc[2k + 1] = cos q_k`; only the joints in [`TRIG`] are read)."
    );
    quote! {
        #[doc = #doc]
        #[inline]
        pub fn #f(q: &[f64; super::NJ], #rest) -> #ret {
            #(#fill)*
            #f_trig(q, &sc, #(#names),*)
        }
        #[doc = #doc_trig]
        #[inline]
        pub fn #f_trig(q: &[f64; super::NJ], sc: &[f64; 2 * super::NJ], #rest) -> #ret {
            let _ = q;
            #(#pre)*
            #body
        }
    }
}

/// One kernel of a configuration: name, doc line, arguments after `q` and their names,
/// return type, outputs and shape (rows, cols; cols 0 for a vector).
type KernelSpec = (
    &'static str,
    &'static str,
    (TokenStream, &'static [&'static str]),
    TokenStream,
    Vec<Atom>,
    (usize, usize),
);

/// Emit one kernel function and count its operations.
#[allow(clippy::too_many_arguments)]
fn kernel(
    sm: &SymbolicModel,
    cd: &ConfigDynamics,
    free: &[usize],
    name: &str,
    doc: &str,
    (rest, names): (&TokenStream, &[&str]),
    ret: &TokenStream,
    outputs: &[Atom],
    shape: (usize, usize),
    ops: &mut Vec<(String, Ops)>,
    trig: &mut Vec<usize>,
) -> TokenStream {
    let Body {
        pre,
        stmts,
        results,
        used,
        ops: o,
    } = body(sm, cd, free, outputs);
    ops.push((name.to_string(), o));
    trig.extend(used.iter().map(|u| u.0));
    let value = if shape.1 == 0 {
        quote!([#(#results),*])
    } else {
        nested(&results, shape.0, shape.1)
    };
    two_forms(
        name,
        doc,
        rest,
        names,
        ret,
        &used,
        &pre,
        quote!(#(#stmts)* #value),
    )
}

// The generation-time checks' random generator: lockstep's one xorshift64*.
use lockstep_rng::Xorshift as Rng;

/// Check a configuration numerically at random states with random physically consistent
/// inertial parameters: D_FF must be positive definite (else the configuration frees a joint
/// that moves no inertia, or two joints that move the same way). Returns the barycentric
/// parameters whose regressor column is not zero (the parameters that appear).
fn check_configuration(
    sm: &SymbolicModel,
    cd: &ConfigDynamics,
    conf: &Configuration,
) -> Result<Vec<usize>, EmitError> {
    let v = &sm.vars;
    let nf = conf.free.len();
    let np = sm.params.len();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut col_norm = vec![0.0f64; np];
    let mut y_max = 0.0f64;
    for _ in 0..3 {
        let mut vals: HashMap<Symbol, f64> = HashMap::new();
        for k in 0..sm.model.joints.len() {
            let q = rng.uniform(-3.0, 3.0);
            vals.insert(v.s[k], q.sin());
            vals.insert(v.c[k], q.cos());
            vals.insert(v.q[k], q * 0.1);
            vals.insert(v.qd[k], rng.uniform(-1.0, 1.0));
            vals.insert(v.qdd[k], rng.uniform(-1.0, 1.0));
        }
        // Per link: m, centroid, centroidal inertia diag + small products → barycentric.
        for l in 0..sm.model.links.len() {
            let m = rng.uniform(1.0, 2.0);
            let c: [f64; 3] = std::array::from_fn(|_| rng.uniform(-0.1, 0.1));
            let ic = [
                rng.uniform(0.05, 0.1),
                rng.uniform(-0.01, 0.01),
                rng.uniform(-0.01, 0.01),
                rng.uniform(0.05, 0.1),
                rng.uniform(-0.01, 0.01),
                rng.uniform(0.05, 0.1),
            ];
            let b = [
                m,
                m * c[0],
                m * c[1],
                m * c[2],
                ic[0] + m * (c[1] * c[1] + c[2] * c[2]),
                ic[1] - m * c[0] * c[1],
                ic[2] - m * c[0] * c[2],
                ic[3] + m * (c[0] * c[0] + c[2] * c[2]),
                ic[4] - m * c[1] * c[2],
                ic[5] + m * (c[0] * c[0] + c[1] * c[1]),
            ];
            for (j, par) in sm.params.iter().enumerate() {
                if par.link == l {
                    vals.insert(sm.p_sym[j], b[par.kind]);
                }
            }
        }
        let d: Vec<f64> = cd.graph.evaluate(&cd.d.concat(), &vals);
        // Cholesky with a relative pivot test.
        let scale = (0..nf).map(|a| d[a * nf + a].abs()).fold(0.0, f64::max);
        let mut l = vec![0.0; nf * nf];
        for i in 0..nf {
            for j in 0..=i {
                let mut x = d[i * nf + j];
                for k in 0..j {
                    x -= l[i * nf + k] * l[j * nf + k];
                }
                if i == j {
                    if x.is_nan() || x <= 1e-9 * scale {
                        return Err(EmitError(format!(
                            "{}: configuration '{}': the inertia matrix D_FF is singular (joint '{}' moves no inertia independently of the joints before it in {:?})",
                            sm.model.file.display(),
                            conf.name,
                            sm.model.joints[conf.free[i]],
                            conf.free.iter().map(|&k| sm.model.joints[k].as_str()).collect::<Vec<_>>()
                        )));
                    }
                    l[i * nf + i] = x.sqrt();
                } else {
                    l[i * nf + j] = x / l[j * nf + j];
                }
            }
        }
        let y = cd.graph.evaluate(&cd.y.concat(), &vals);
        for (i, x) in y.iter().enumerate() {
            col_norm[i % np] += x * x;
            y_max = y_max.max(x.abs());
        }
    }
    Ok((0..np)
        .filter(|&j| col_norm[j].sqrt() > 1e-12 * y_max.max(1.0))
        .collect())
}

/// Forward dynamics split for a simulation (loop-invariant code motion): what depends only
/// on the locked joints' trigonometry and on p is computed once per run by
/// `forward_dynamics_invariants(q, sc, p) -> [f64; FORWARD_DYNAMICS_INVARIANTS]`, and
/// `forward_dynamics_trig_inv(q, sc, qd, tau, p, inv)` computes the rest at each stage. The
/// same expressions as `forward_dynamics_trig`, so the same bits. `dh` are D's lower
/// triangle and h, `used` the joints whose trigonometry they read, `solve` the tail from
/// their results.
fn hoisted_forward_dynamics(
    sm: &SymbolicModel,
    cd: &ConfigDynamics,
    free: &[usize],
    dh: &[Atom],
    used: &[(usize, bool, bool)],
    solve: &dyn Fn(&[TokenStream]) -> TokenStream,
) -> TokenStream {
    let v = &sm.vars;
    let varies = |s: Symbol| {
        free.iter()
            .any(|&k| s == v.s[k] || s == v.c[k] || s == v.q[k])
            || v.qd.contains(&s)
            || v.qdd.contains(&s)
    };
    let h = cd
        .graph
        .emit_hoisted(dh, &|s| sm.spelling(free, s), &varies);
    let prelude = |set: &std::collections::HashSet<Symbol>| {
        let used: Vec<(usize, bool, bool)> = used
            .iter()
            .map(|&(k, s, c)| (k, s && set.contains(&v.s[k]), c && set.contains(&v.c[k])))
            .filter(|&(_, s, c)| s || c)
            .collect();
        trig_prelude(&used)
    };
    let (pre_inv, pre_var) = (prelude(&h.invariant_inputs), prelude(&h.varying_inputs));
    let k = h.frontier.len();
    let (invariant, frontier, varying) = (&h.invariant, &h.frontier, &h.varying);
    let tail = solve(&h.results);
    let np_ts = quote!(super::NP);
    quote! {
        /// Number of [`forward_dynamics_invariants`]' values.
        pub const FORWARD_DYNAMICS_INVARIANTS: usize = #k;
        /// The intermediates of [`forward_dynamics_trig`] that depend only on the locked
        /// joints' positions (their sines and cosines in `sc`) and on `p`: computed once per
        /// simulation for [`forward_dynamics_trig_inv`].
        #[inline]
        pub fn forward_dynamics_invariants(
            q: &[f64; super::NJ],
            sc: &[f64; 2 * super::NJ],
            p: &[f64; #np_ts],
        ) -> [f64; FORWARD_DYNAMICS_INVARIANTS] {
            let _ = (q, sc, p);
            #(#pre_inv)*
            #(#invariant)*
            [#(#frontier),*]
        }
        /// [`forward_dynamics_trig`] reading its loop invariants from `inv`
        /// ([`forward_dynamics_invariants`] of the same locked positions and `p`): the same
        /// values, computing only what depends on the free joints' state and `tau`.
        #[inline]
        pub fn forward_dynamics_trig_inv(
            q: &[f64; super::NJ],
            sc: &[f64; 2 * super::NJ],
            qd: &[f64; NF],
            tau: &[f64; NF],
            p: &[f64; #np_ts],
            inv: &[f64; FORWARD_DYNAMICS_INVARIANTS],
        ) -> [f64; NF] {
            let _ = (q, sc, qd, p, inv);
            #(#pre_var)*
            #(#varying)*
            #tail
        }
    }
}

/// Unrolled Cholesky solve of `D x = b` (D symmetric positive definite, NF × NF).
fn cholesky_solve(nf: usize) -> TokenStream {
    let mut st = Vec::new();
    let l = |i: usize, j: usize| id(&format!("l{i}_{j}"));
    for i in 0..nf {
        for j in 0..=i {
            let dij = {
                let (i, j) = (
                    proc_macro2::Literal::usize_unsuffixed(i),
                    proc_macro2::Literal::usize_unsuffixed(j),
                );
                quote!(d[#i][#j])
            };
            let sub: Vec<TokenStream> = (0..j)
                .map(|k| {
                    let (a, b) = (l(i, k), l(j, k));
                    quote!(- #a * #b)
                })
                .collect();
            let lij = l(i, j);
            if i == j {
                st.push(quote!(let #lij = (#dij #(#sub)*).sqrt();));
            } else {
                let ljj = l(j, j);
                st.push(quote!(let #lij = (#dij #(#sub)*) / #ljj;));
            }
        }
    }
    let yv = |i: usize| id(&format!("y{i}"));
    let xv = |i: usize| id(&format!("x{i}"));
    for i in 0..nf {
        let ii = proc_macro2::Literal::usize_unsuffixed(i);
        let sub: Vec<TokenStream> = (0..i)
            .map(|k| {
                let (a, b) = (l(i, k), yv(k));
                quote!(- #a * #b)
            })
            .collect();
        let (yi, lii) = (yv(i), l(i, i));
        st.push(quote!(let #yi = (rhs[#ii] #(#sub)*) / #lii;));
    }
    for i in (0..nf).rev() {
        let sub: Vec<TokenStream> = (i + 1..nf)
            .map(|k| {
                let (a, b) = (l(k, i), xv(k));
                quote!(- #a * #b)
            })
            .collect();
        let (xi, yi, lii) = (xv(i), yv(i), l(i, i));
        st.push(quote!(let #xi = (#yi #(#sub)*) / #lii;));
    }
    let xs: Vec<Ident> = (0..nf).map(xv).collect();
    quote! {
        #(#st)*
        [#(#xs),*]
    }
}

fn config_module(
    sm: &SymbolicModel,
    conf: &Configuration,
) -> Result<(TokenStream, ConfigReport), EmitError> {
    let t0 = Instant::now();
    let free = &conf.free;
    let nf = free.len();
    let mut cd = config_dynamics(sm.model, &sm.vars, &sm.tree, &sm.params, &sm.p_sym, free);
    let present = check_configuration(sm, &cd, conf)?;
    // The state derivatives of the inverse dynamics at fixed q̈, beside D (one body: they
    // share most intermediates), for the sensitivities of forward dynamics:
    // ∂q̈/∂x = D⁻¹ (∂Q/∂x − ∂τ/∂x).
    let mut derivatives: Vec<Atom> = Vec::with_capacity(3 * nf * nf);
    for a in 0..nf {
        derivatives.extend(cd.d[a].iter().cloned());
        let tau_a = cd.tau[a].clone();
        for &k in free {
            derivatives.push(cd.graph.derivative(&tau_a, Direction::Joint(k)));
        }
        for &k in free {
            derivatives.push(cd.graph.derivative(&tau_a, Direction::Velocity(k)));
        }
    }
    let mut ops = Vec::new();
    // The joints whose trigonometry any kernel reads.
    let mut trig: Vec<usize> = Vec::new();
    let flat = |m: &Vec<Vec<Atom>>| -> Vec<Atom> { m.iter().flatten().cloned().collect() };
    let np_ts = quote!(super::NP);
    let table: Vec<KernelSpec> = vec![
        (
            "mass_matrix",
            "Inertia matrix D_FF(q) (thesis 3.2), NF × NF, kg·m² (kg for prismatic rows).",
            (quote!(p: &[f64; #np_ts]), &["p"]),
            quote!([[f64; NF]; NF]),
            flat(&cd.d),
            (nf, nf),
        ),
        (
            "christoffel_matrix",
            "Christoffel matrix C_FF(q, q̇) (thesis 3.3): C_kj = Σ_i Γ_ijk q̇_i, NF × NF.",
            (quote!(qd: &[f64; NF], p: &[f64; #np_ts]), &["qd", "p"]),
            quote!([[f64; NF]; NF]),
            flat(&cd.c),
            (nf, nf),
        ),
        (
            "coriolis",
            "Coriolis and centrifugal torques C_FF(q, q̇) q̇_F, NF (N·m or N).",
            (quote!(qd: &[f64; NF], p: &[f64; #np_ts]), &["qd", "p"]),
            quote!([f64; NF]),
            cd.cqd.clone(),
            (nf, 0),
        ),
        (
            "gravity",
            "Gravity torques φ_F(q) (thesis 3.4), NF (N·m or N).",
            (quote!(p: &[f64; #np_ts]), &["p"]),
            quote!([f64; NF]),
            cd.phi.clone(),
            (nf, 0),
        ),
        (
            "inverse_dynamics",
            "Inverse dynamics τ_F = D q̈ + C q̇ + φ (thesis 3.5), NF (N·m or N).",
            (
                quote!(qd: &[f64; NF], qdd: &[f64; NF], p: &[f64; #np_ts]),
                &["qd", "qdd", "p"],
            ),
            quote!([f64; NF]),
            cd.tau.clone(),
            (nf, 0),
        ),
        (
            "dynamics_derivatives",
            "Row a: [D_a (NF), ∂τ_a/∂q_F (NF), ∂τ_a/∂q̇_F (NF)], τ_F = D q̈ + C q̇ + φ at fixed \
             q̈ (thesis 3.5): the state derivatives of forward dynamics are \
             ∂q̈/∂x = D⁻¹ (∂Q/∂x − ∂τ/∂x), Q the applied torques. NF × 3NF.",
            (
                quote!(qd: &[f64; NF], qdd: &[f64; NF], p: &[f64; #np_ts]),
                &["qd", "qdd", "p"],
            ),
            quote!([[f64; 3 * NF]; NF]),
            derivatives,
            (nf, 3 * nf),
        ),
        (
            "regressor",
            "Regressor Y_F(q, q̇, q̈) with τ_F = Y_F p, NF × NP.",
            (quote!(qd: &[f64; NF], qdd: &[f64; NF]), &["qd", "qdd"]),
            quote!([[f64; #np_ts]; NF]),
            flat(&cd.y),
            (nf, sm.params.len()),
        ),
    ];
    let mut items: Vec<TokenStream> = table
        .iter()
        .map(|(name, doc, (rest, names), ret, outputs, shape)| {
            kernel(
                sm,
                &cd,
                free,
                name,
                doc,
                (rest, names),
                ret,
                outputs,
                *shape,
                &mut ops,
                &mut trig,
            )
        })
        .collect();
    // Forward dynamics: D (lower triangle) and h = C q̇ + φ in one body, then Cholesky.
    let mut dh: Vec<Atom> = Vec::new();
    for a in 0..nf {
        for b in 0..=a {
            dh.push(cd.d[a][b].clone());
        }
    }
    dh.extend(cd.h.iter().cloned());
    let Body {
        pre,
        stmts,
        results,
        used,
        ops: o,
    } = body(sm, &cd, free, &dh);
    trig.extend(used.iter().map(|u| u.0));
    // D's lower triangle and h as results → D, the right-hand side τ − h and the solve.
    let solve = |results: &[TokenStream]| -> TokenStream {
        let mut k = 0;
        let mut d_rows = Vec::new();
        for a in 0..nf {
            let mut row = Vec::new();
            for _ in 0..=a {
                row.push(results[k].clone());
                k += 1;
            }
            d_rows.push(row);
        }
        let mut d_full = Vec::new();
        for a in 0..nf {
            let row: Vec<TokenStream> = (0..nf)
                .map(|b| {
                    if b <= a {
                        d_rows[a][b].clone()
                    } else {
                        d_rows[b][a].clone()
                    }
                })
                .collect();
            d_full.push(quote!([#(#row),*]));
        }
        let h: Vec<TokenStream> = results[k..].to_vec();
        let rhs: Vec<TokenStream> = (0..nf)
            .map(|a| {
                let aa = proc_macro2::Literal::usize_unsuffixed(a);
                let ha = &h[a];
                quote!(tau[#aa] - #ha)
            })
            .collect();
        let chol = cholesky_solve(nf);
        quote! {
            let d: [[f64; NF]; NF] = [#(#d_full),*];
            let rhs: [f64; NF] = [#(#rhs),*];
            #chol
        }
    };
    let solve_all = solve(&results);
    let mut fo = o;
    // Cholesky (n³/6 multiply-adds, n square roots) and two triangular solves.
    fo.add += nf + (nf * nf * nf - nf) / 6 + nf * (nf - 1);
    fo.mul += (nf * nf * nf - nf) / 6 + nf * (nf - 1);
    fo.other += nf + nf * (nf - 1) / 2 + 2 * nf;
    ops.push(("forward_dynamics".into(), fo));
    items.push(two_forms(
        "forward_dynamics",
        "Forward dynamics q̈_F = D_FF⁻¹ (τ_F − C q̇ − φ) by an unrolled Cholesky \
         factorisation, NF (rad/s² or m/s²). NaN when D_FF is not positive definite.",
        &quote!(qd: &[f64; NF], tau: &[f64; NF], p: &[f64; #np_ts]),
        &["qd", "tau", "p"],
        &quote!([f64; NF]),
        &used,
        &pre,
        quote! {
            #(#stmts)*
            #solve_all
        },
    ));
    items.push(hoisted_forward_dynamics(sm, &cd, free, &dh, &used, &solve));
    trig.sort_unstable();
    trig.dedup();
    let trig_lits: Vec<proc_macro2::Literal> = trig
        .iter()
        .map(|&k| proc_macro2::Literal::usize_unsuffixed(k))
        .collect();
    let present_names: Vec<String> = present.iter().map(|&j| sm.params[j].name.clone()).collect();
    let present_idx: Vec<proc_macro2::Literal> = present
        .iter()
        .map(|&j| proc_macro2::Literal::usize_unsuffixed(j))
        .collect();
    let free_lits: Vec<proc_macro2::Literal> = free
        .iter()
        .map(|&k| proc_macro2::Literal::usize_unsuffixed(k))
        .collect();
    let modname = id(&conf.name);
    let cname = &conf.name;
    let free_names: Vec<String> = free.iter().map(|&k| sm.model.joints[k].clone()).collect();
    let total: usize = ops.iter().map(|(_, o)| o.total()).sum();
    let doc = format!(
        "Configuration `{}`: free joints {} (locked joints: q̇ = q̈ = 0). {} operations in all kernels.",
        conf.name,
        free_names.join(", "),
        total
    );
    let ops_doc: Vec<String> = ops
        .iter()
        .map(|(n, o)| format!("`{n}`: {} add, {} mul, {} other", o.add, o.mul, o.other))
        .collect();
    let ops_doc = format!("Operation counts: {}.", ops_doc.join("; "));
    let tokens = quote! {
        #[doc = #doc]
        #[doc = ""]
        #[doc = #ops_doc]
        pub mod #modname {
            /// Number of free joints.
            pub const NF: usize = #nf;
            /// Free joint indices.
            pub const FREE: [usize; NF] = [#(#free_lits),*];
            /// Barycentric parameters present in this configuration's equations.
            pub const PARAMS_PRESENT: &[usize] = &[#(#present_idx),*];
            /// Joints whose sine and cosine the kernels read (the `_trig` forms' table).
            pub const TRIG: &[usize] = &[#(#trig_lits),*];
            #(#items)*

            pub(crate) fn mass_matrix_dyn(q: &[f64], p: &[f64], out: &mut [f64]) {
                let m = mass_matrix(q.try_into().unwrap(), p.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
            }
            pub(crate) fn christoffel_matrix_dyn(q: &[f64], qd: &[f64], p: &[f64], out: &mut [f64]) {
                let m = christoffel_matrix(q.try_into().unwrap(), qd.try_into().unwrap(), p.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
            }
            pub(crate) fn coriolis_dyn(q: &[f64], qd: &[f64], p: &[f64], out: &mut [f64]) {
                out.copy_from_slice(&coriolis(q.try_into().unwrap(), qd.try_into().unwrap(), p.try_into().unwrap()));
            }
            pub(crate) fn gravity_dyn(q: &[f64], p: &[f64], out: &mut [f64]) {
                out.copy_from_slice(&gravity(q.try_into().unwrap(), p.try_into().unwrap()));
            }
            pub(crate) fn inverse_dynamics_dyn(q: &[f64], qd: &[f64], qdd: &[f64], p: &[f64], out: &mut [f64]) {
                out.copy_from_slice(&inverse_dynamics(q.try_into().unwrap(), qd.try_into().unwrap(), qdd.try_into().unwrap(), p.try_into().unwrap()));
            }
            pub(crate) fn forward_dynamics_dyn(q: &[f64], qd: &[f64], tau: &[f64], p: &[f64], out: &mut [f64]) {
                out.copy_from_slice(&forward_dynamics(q.try_into().unwrap(), qd.try_into().unwrap(), tau.try_into().unwrap(), p.try_into().unwrap()));
            }
            pub(crate) fn dynamics_derivatives_dyn(q: &[f64], qd: &[f64], qdd: &[f64], p: &[f64], out: &mut [f64]) {
                let m = dynamics_derivatives(q.try_into().unwrap(), qd.try_into().unwrap(), qdd.try_into().unwrap(), p.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
            }
            pub(crate) fn regressor_dyn(q: &[f64], qd: &[f64], qdd: &[f64], out: &mut [f64]) {
                let m = regressor(q.try_into().unwrap(), qd.try_into().unwrap(), qdd.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
            }
            pub(crate) fn mass_matrix_trig_dyn(q: &[f64], sc: &[f64], p: &[f64], out: &mut [f64]) {
                let m = mass_matrix_trig(q.try_into().unwrap(), sc.try_into().unwrap(), p.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
            }
            pub(crate) fn forward_dynamics_trig_dyn(q: &[f64], sc: &[f64], qd: &[f64], tau: &[f64], p: &[f64], out: &mut [f64]) {
                out.copy_from_slice(&forward_dynamics_trig(q.try_into().unwrap(), sc.try_into().unwrap(), qd.try_into().unwrap(), tau.try_into().unwrap(), p.try_into().unwrap()));
            }
            pub(crate) fn forward_dynamics_invariants_dyn(q: &[f64], sc: &[f64], p: &[f64], out: &mut [f64]) {
                out.copy_from_slice(&forward_dynamics_invariants(q.try_into().unwrap(), sc.try_into().unwrap(), p.try_into().unwrap()));
            }
            pub(crate) fn forward_dynamics_trig_inv_dyn(q: &[f64], sc: &[f64], qd: &[f64], tau: &[f64], p: &[f64], inv: &[f64], out: &mut [f64]) {
                out.copy_from_slice(&forward_dynamics_trig_inv(q.try_into().unwrap(), sc.try_into().unwrap(), qd.try_into().unwrap(), tau.try_into().unwrap(), p.try_into().unwrap(), inv.try_into().unwrap()));
            }
            pub(crate) fn dynamics_derivatives_trig_dyn(q: &[f64], sc: &[f64], qd: &[f64], qdd: &[f64], p: &[f64], out: &mut [f64]) {
                let m = dynamics_derivatives_trig(q.try_into().unwrap(), sc.try_into().unwrap(), qd.try_into().unwrap(), qdd.try_into().unwrap(), p.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
            }
            pub(crate) fn regressor_trig_dyn(q: &[f64], sc: &[f64], qd: &[f64], qdd: &[f64], out: &mut [f64]) {
                let m = regressor_trig(q.try_into().unwrap(), sc.try_into().unwrap(), qd.try_into().unwrap(), qdd.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
            }
            pub(crate) const CONFIGURATION: crate::Configuration = crate::Configuration {
                name: #cname,
                free: &FREE,
                params_present: PARAMS_PRESENT,
                mass_matrix: mass_matrix_dyn,
                christoffel_matrix: christoffel_matrix_dyn,
                coriolis: coriolis_dyn,
                gravity: gravity_dyn,
                inverse_dynamics: inverse_dynamics_dyn,
                forward_dynamics: forward_dynamics_dyn,
                dynamics_derivatives: dynamics_derivatives_dyn,
                regressor: regressor_dyn,
                trig: TRIG,
                mass_matrix_trig: mass_matrix_trig_dyn,
                forward_dynamics_trig: forward_dynamics_trig_dyn,
                forward_dynamics_invariant_count: FORWARD_DYNAMICS_INVARIANTS,
                forward_dynamics_invariants: forward_dynamics_invariants_dyn,
                forward_dynamics_trig_inv: forward_dynamics_trig_inv_dyn,
                dynamics_derivatives_trig: dynamics_derivatives_trig_dyn,
                regressor_trig: regressor_trig_dyn,
            };
        }
    };
    let report = ConfigReport {
        name: conf.name.clone(),
        free: free_names,
        params_present: present_names,
        ops,
        seconds: t0.elapsed().as_secs_f64(),
    };
    Ok((tokens, report))
}

/// Generate the kernels module of a model for the named configurations (all when `None`).
///
/// # Errors
/// [`EmitError`] when an evaluator cannot be built or translated, or a configuration name is
/// unknown.
pub fn generate(model: &Model, only: Option<&[String]>) -> Result<Generated, EmitError> {
    let t0 = Instant::now();
    let sm = SymbolicModel::new(model);
    let model_seconds = t0.elapsed().as_secs_f64();
    if let Some(names) = only {
        for n in names {
            if model.configuration(n).is_none() {
                return Err(EmitError(format!(
                    "{}: unknown configuration '{n}' (configurations: {})",
                    model.file.display(),
                    model
                        .configurations
                        .iter()
                        .map(|c| c.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
        }
    }
    let mut mods = Vec::new();
    let mut reports = Vec::new();
    let mut conf_idents = Vec::new();
    for conf in &model.configurations {
        if let Some(names) = only {
            if !names.contains(&conf.name) {
                continue;
            }
        }
        let (ts, rep) = config_module(&sm, conf)?;
        mods.push(ts);
        reports.push(rep);
        conf_idents.push(id(&conf.name));
    }
    // Barycentric parameters from the model file's inertial symbols.
    let sym_list: Vec<Symbol> = model
        .inertial_symbols
        .iter()
        .map(|(s, _, _)| user_symbol(s))
        .collect();
    let bary_exprs: Vec<Atom> = sm.params.iter().map(|b| b.expr.clone()).collect();
    let (bstmts, bres, _) = Graph::new(Inputs::default(), "").emit(&bary_exprs, &|s| {
        let i = sym_list.iter().position(|&x| x == s)?;
        let i = proc_macro2::Literal::usize_unsuffixed(i);
        Some(quote!(u[#i]))
    });
    let nj = model.joints.len();
    let np = sm.params.len();
    let ni = sym_list.len();
    let joints = &model.joints;
    let pnames: Vec<&str> = sm.params.iter().map(|b| b.name.as_str()).collect();
    let plinks: Vec<proc_macro2::Literal> = sm
        .params
        .iter()
        .map(|b| proc_macro2::Literal::usize_unsuffixed(b.link))
        .collect();
    let pkinds: Vec<proc_macro2::Literal> = sm
        .params
        .iter()
        .map(|b| proc_macro2::Literal::usize_unsuffixed(b.kind))
        .collect();
    let lnames: Vec<&str> = model.links.iter().map(|l| l.name.as_str()).collect();
    let nl = lnames.len();
    let snames: Vec<&str> = model
        .inertial_symbols
        .iter()
        .map(|(s, _, _)| s.as_str())
        .collect();
    let slinks: Vec<proc_macro2::Literal> = model
        .inertial_symbols
        .iter()
        .map(|&(_, l, _)| proc_macro2::Literal::usize_unsuffixed(l))
        .collect();
    let sroles: Vec<proc_macro2::Literal> = model
        .inertial_symbols
        .iter()
        .map(|&(_, _, r)| proc_macro2::Literal::usize_unsuffixed(r))
        .collect();
    let sdefaults: Vec<TokenStream> = model
        .inertial_symbols
        .iter()
        .map(|(s, _, _)| match model.defaults.get(s) {
            Some(&v) if v < 0.0 => {
                let l = proc_macro2::Literal::f64_unsuffixed(-v);
                quote!(Some(-#l))
            }
            Some(&v) => {
                let l = proc_macro2::Literal::f64_unsuffixed(v);
                quote!(Some(#l))
            }
            None => quote!(None),
        })
        .collect();
    let description = crate::describe::describe(model);
    let dh = match crate::dh::equivalent_dh(model) {
        Ok(t) => quote!(Ok(#t)),
        Err(e) => quote!(Err(#e)),
    };
    let mname = &model.name;
    // Locking sequences whose steps were all generated.
    let seqs: Vec<TokenStream> = model
        .sequences
        .iter()
        .filter(|(_, steps)| {
            steps.iter().all(|&i| {
                conf_idents
                    .iter()
                    .any(|c| *c == model.configurations[i].name)
            })
        })
        .map(|(name, steps)| {
            let names: Vec<&str> = steps
                .iter()
                .map(|&i| model.configurations[i].name.as_str())
                .collect();
            quote!((#name, &[#(#names),*]))
        })
        .collect();
    let gravity: Vec<TokenStream> = model.gravity.iter().map(|&g| lit(g)).collect();
    let file = quote! {
        /// Number of joints.
        pub const NJ: usize = #nj;
        /// Number of barycentric parameters.
        pub const NP: usize = #np;
        /// Number of inertial symbols in the model file.
        pub const NI: usize = #ni;
        /// Joint variable names.
        pub const JOINTS: [&str; NJ] = [#(#joints),*];
        /// Barycentric parameter names.
        pub const PARAMS: [&str; NP] = [#(#pnames),*];
        /// Link of each barycentric parameter.
        pub const PARAM_LINK: [usize; NP] = [#(#plinks),*];
        /// Kind of each barycentric parameter (index into `inertia::BARYCENTRIC_KINDS`).
        pub const PARAM_KIND: [usize; NP] = [#(#pkinds),*];
        /// Link names.
        pub const LINKS: [&str; #nl] = [#(#lnames),*];
        /// Inertial symbols of the model file (thesis form).
        pub const INERTIAL_SYMBOLS: [&str; NI] = [#(#snames),*];
        /// Link of each inertial symbol.
        pub const SYMBOL_LINK: [usize; NI] = [#(#slinks),*];
        /// Role of each inertial symbol: 0 = mass, 1 = centroid, 2 = inertia about the centroid.
        pub const SYMBOL_ROLE: [usize; NI] = [#(#sroles),*];
        /// Default value of each inertial symbol (the model file's `[defaults]` or its URDF's
        /// `<inertial>` numbers), `None` where it has none.
        pub const SYMBOL_DEFAULTS: [Option<f64>; NI] = [#(#sdefaults),*];
        /// What the generator read: joints, frames, links with their default values,
        /// configurations (`lockstep model show`).
        pub const DESCRIPTION: &str = #description;
        /// The equivalent modified DH table as model-file TOML, or why none exists
        /// (`lockstep model dh`).
        pub const DH_TABLE: Result<&str, &str> = #dh;
        /// Gravity in frame 0 (m/s²).
        pub const GRAVITY: [f64; 3] = [#(#gravity),*];

        /// Barycentric parameters (m, m·c, inertia about the frame origin) from the model
        /// file's inertial symbols (m, centroid, inertia about the centroid), NI → NP.
        pub fn barycentric_from_symbols(u: &[f64; NI]) -> [f64; NP] {
            #(#bstmts)*
            [#(#bres),*]
        }
        fn barycentric_from_symbols_dyn(u: &[f64], out: &mut [f64]) {
            out.copy_from_slice(&barycentric_from_symbols(u.try_into().unwrap()));
        }

        #(#mods)*

        /// The model behind slices.
        pub static MODEL: crate::Model = crate::Model {
            name: #mname,
            joints: &JOINTS,
            params: &PARAMS,
            param_link: &PARAM_LINK,
            param_kind: &PARAM_KIND,
            links: &LINKS,
            inertial_symbols: &INERTIAL_SYMBOLS,
            symbol_link: &SYMBOL_LINK,
            symbol_role: &SYMBOL_ROLE,
            symbol_defaults: &SYMBOL_DEFAULTS,
            description: DESCRIPTION,
            dh_table: DH_TABLE,
            barycentric_from_symbols: barycentric_from_symbols_dyn,
            configurations: &[#(#conf_idents::CONFIGURATION),*],
            sequences: &[#(#seqs),*],
        };
    };
    let file_str = file.to_string();
    let parsed: syn::File = syn::parse_str(&file_str)
        .map_err(|e| EmitError(format!("emitted code does not parse: {e}")))?;
    let body = prettyplease::unparse(&parsed);
    let mut header = String::new();
    header.push_str(&format!(
        "// Generated by lockstep-codegen {GENERATOR_VERSION} from {} (model '{}'). Do not edit.\n",
        model
            .file
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default(),
        model.name
    ));
    header.push_str(&format!(
        "// Joints: {}. Barycentric parameters: {}.\n",
        model.joints.join(", "),
        np
    ));
    for r in &reports {
        let total: usize = r.ops.iter().map(|(_, o)| o.total()).sum();
        header.push_str(&format!(
            "// Configuration {}: free {}; {} operations ({}).\n",
            r.name,
            r.free.join(", "),
            total,
            r.ops
                .iter()
                .map(|(n, o)| format!("{n} {}", o.total()))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok(Generated {
        source: format!("{header}\n{body}"),
        configs: reports,
        model_seconds,
    })
}
