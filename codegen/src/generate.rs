//! From a validated model to the Rust source of its kernels module.

use crate::emit::{lit, straight_line, EmitError, Ops};
use crate::model::{Configuration, Model};
use crate::symbolic::{self, christoffel, reduce, user_symbol, Vars};
use proc_macro2::{Ident, Span, TokenStream};
use quote::quote;
use std::time::Instant;
use symbolica::atom::{Atom, AtomCore};

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
    /// Barycentric parameters.
    pub params: Vec<symbolic::Barycentric>,
    /// `p_sym[j]`: the parameter's symbol `P{j}`.
    pub p_sym: Vec<Atom>,
    /// D and φ coefficients.
    pub coef: symbolic::Coefficients,
    /// ∂d⁽ʲ⁾_ab/∂q_i, `[j][a][b][i]`.
    pub dd: Vec<Vec<Vec<Vec<Atom>>>>,
}

impl<'m> SymbolicModel<'m> {
    /// Form the full model symbolically.
    pub fn new(model: &'m Model) -> SymbolicModel<'m> {
        let vars = Vars::new(model);
        let poses = symbolic::frame_poses(model, &vars);
        let params = symbolic::barycentric(model, &vars);
        let coef = symbolic::coefficients(model, &vars, &poses, &params);
        let n = model.joints.len();
        let dd = coef
            .d
            .iter()
            .map(|dj| {
                let mut m = vec![vec![vec![Atom::num(0); n]; n]; n];
                for a in 0..n {
                    for b in a..n {
                        if dj[a][b].is_zero() {
                            continue;
                        }
                        for i in 0..n {
                            let e = vars.dq(&dj[a][b], i);
                            m[a][b][i] = e.clone();
                            m[b][a][i] = e;
                        }
                    }
                }
                m
            })
            .collect();
        let p_sym = (0..params.len())
            .map(|j| Atom::var(symbolica::symbol!(&format!("lockstep::P{j}"))))
            .collect();
        SymbolicModel {
            model,
            vars,
            params,
            p_sym,
            coef,
            dd,
        }
    }
}

/// Inputs of a configuration's evaluators and their Rust spellings.
struct Inputs {
    atoms: Vec<Atom>,
    tokens: Vec<TokenStream>,
}

fn inputs(
    sm: &SymbolicModel,
    free: &[usize],
    with_qd: bool,
    with_qdd: bool,
    with_p: bool,
) -> Inputs {
    let v = &sm.vars;
    let mut atoms = Vec::new();
    let mut tokens = Vec::new();
    for k in 0..sm.model.joints.len() {
        if v.revolute[k] {
            let (s, c) = (id(&format!("s{k}")), id(&format!("c{k}")));
            atoms.push(Atom::var(v.s[k]));
            tokens.push(quote!(#s));
            atoms.push(Atom::var(v.c[k]));
            tokens.push(quote!(#c));
        }
        if v.prismatic[k] {
            atoms.push(Atom::var(v.q[k]));
            let k = proc_macro2::Literal::usize_unsuffixed(k);
            tokens.push(quote!(q[#k]));
        }
    }
    for (a, &k) in free.iter().enumerate() {
        let a = proc_macro2::Literal::usize_unsuffixed(a);
        if with_qd {
            atoms.push(Atom::var(v.qd[k]));
            tokens.push(quote!(qd[#a]));
        }
        if with_qdd {
            atoms.push(Atom::var(v.qdd[k]));
            tokens.push(quote!(qdd[#a]));
        }
    }
    if with_p {
        for (j, p) in sm.p_sym.iter().enumerate() {
            atoms.push(p.clone());
            let j = proc_macro2::Literal::usize_unsuffixed(j);
            tokens.push(quote!(p[#j]));
        }
    }
    Inputs { atoms, tokens }
}

/// `let s{k} = q[k].sin(); let c{k} = q[k].cos();` for revolute joints used by `outputs`.
fn trig_prelude(sm: &SymbolicModel, outputs: &[Atom]) -> Vec<TokenStream> {
    let v = &sm.vars;
    let mut out = Vec::new();
    for k in 0..sm.model.joints.len() {
        if !v.revolute[k] {
            continue;
        }
        let used_s = outputs.iter().any(|o| o.contains_symbol(v.s[k]));
        let used_c = outputs.iter().any(|o| o.contains_symbol(v.c[k]));
        let kk = proc_macro2::Literal::usize_unsuffixed(k);
        if used_s && used_c {
            let (s, c) = (id(&format!("s{k}")), id(&format!("c{k}")));
            out.push(quote!(let (#s, #c) = q[#kk].sin_cos();));
        } else if used_s {
            let s = id(&format!("s{k}"));
            out.push(quote!(let #s = q[#kk].sin();));
        } else if used_c {
            let c = id(&format!("c{k}"));
            out.push(quote!(let #c = q[#kk].cos();));
        }
    }
    out
}

/// Per-configuration symbolic outputs.
struct ConfigExprs {
    /// D_FF, NF × NF.
    d: Vec<Vec<Atom>>,
    /// C_FF, NF × NF.
    c: Vec<Vec<Atom>>,
    /// φ_F.
    phi: Vec<Atom>,
    /// Y_F, NF × NP.
    y: Vec<Vec<Atom>>,
    /// Parameters present.
    present: Vec<usize>,
}

fn config_exprs(sm: &SymbolicModel, free: &[usize]) -> ConfigExprs {
    let v = &sm.vars;
    let nf = free.len();
    let np = sm.params.len();
    let mut d = vec![vec![Atom::num(0); nf]; nf];
    let mut c = vec![vec![Atom::num(0); nf]; nf];
    let mut phi = vec![Atom::num(0); nf];
    let mut y = vec![vec![Atom::num(0); np]; nf];
    let mut present = Vec::new();
    for j in 0..np {
        let pj = &sm.p_sym[j];
        let mut used = false;
        // C⁽ʲ⁾_ab = Σ_{i∈F} Γ_{i, F[b], F[a]} q̇_i.
        let mut cj = vec![vec![Atom::num(0); nf]; nf];
        for a in 0..nf {
            for b in 0..nf {
                let mut acc = Atom::num(0);
                for &i in free {
                    acc += christoffel(&sm.dd, j, i, free[b], free[a]) * Atom::var(v.qd[i]);
                }
                cj[a][b] = reduce(&acc, v);
            }
        }
        for a in 0..nf {
            let mut ya = sm.coef.phi[j][free[a]].clone();
            if !ya.is_zero() {
                used = true;
            }
            phi[a] = &phi[a] + pj * &sm.coef.phi[j][free[a]];
            for b in 0..nf {
                let dab = &sm.coef.d[j][free[a]][free[b]];
                if !dab.is_zero() {
                    used = true;
                }
                d[a][b] = &d[a][b] + pj * dab;
                c[a][b] = &c[a][b] + pj * &cj[a][b];
                ya = ya + dab * Atom::var(v.qdd[free[b]]) + &cj[a][b] * Atom::var(v.qd[free[b]]);
            }
            y[a][j] = reduce(&ya, v);
        }
        if used {
            present.push(j);
        }
    }
    ConfigExprs {
        d,
        c,
        phi,
        y,
        present,
    }
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

/// Emit one kernel function and count its operations.
#[allow(clippy::too_many_arguments)]
fn kernel(
    sm: &SymbolicModel,
    name: &str,
    doc: &str,
    args: TokenStream,
    ret: TokenStream,
    outputs: &[Atom],
    inp: &Inputs,
    shape: (usize, usize),
    ops: &mut Vec<(String, Ops)>,
) -> Result<TokenStream, EmitError> {
    let (stmts, results, o) = straight_line(outputs, &inp.atoms, &inp.tokens, "")?;
    ops.push((name.to_string(), o));
    let pre = trig_prelude(sm, outputs);
    let body = if shape.1 == 0 {
        quote!([#(#results),*])
    } else {
        nested(&results, shape.0, shape.1)
    };
    let f = id(name);
    Ok(quote! {
        #[doc = #doc]
        #[inline]
        pub fn #f(#args) -> #ret {
            #(#pre)*
            #(#stmts)*
            #body
        }
    })
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
    let ex = config_exprs(sm, free);
    let mut ops = Vec::new();
    let flat = |m: &Vec<Vec<Atom>>| -> Vec<Atom> { m.iter().flatten().cloned().collect() };
    let nj_ts = quote!(super::NJ);
    let np_ts = quote!(super::NP);
    let full_inp = inputs(sm, free, true, true, true);
    let qp_inp = inputs(sm, free, false, false, true);
    let qqdp_inp = inputs(sm, free, true, false, true);
    let y_inp = inputs(sm, free, true, true, false);
    let mut items = Vec::new();
    items.push(kernel(
        sm,
        "mass_matrix",
        "Inertia matrix D_FF(q) (thesis 3.2), NF × NF, kg·m² (kg for prismatic rows).",
        quote!(q: &[f64; #nj_ts], p: &[f64; #np_ts]),
        quote!([[f64; NF]; NF]),
        &flat(&ex.d),
        &qp_inp,
        (nf, nf),
        &mut ops,
    )?);
    items.push(kernel(
        sm,
        "christoffel_matrix",
        "Christoffel matrix C_FF(q, q̇) (thesis 3.3): C_kj = Σ_i Γ_ijk q̇_i, NF × NF.",
        quote!(q: &[f64; #nj_ts], qd: &[f64; NF], p: &[f64; #np_ts]),
        quote!([[f64; NF]; NF]),
        &flat(&ex.c),
        &qqdp_inp,
        (nf, nf),
        &mut ops,
    )?);
    let cqd: Vec<Atom> = (0..nf)
        .map(|a| {
            (0..nf).fold(Atom::num(0), |acc, b| {
                acc + &ex.c[a][b] * Atom::var(sm.vars.qd[free[b]])
            })
        })
        .collect();
    items.push(kernel(
        sm,
        "coriolis",
        "Coriolis and centrifugal torques C_FF(q, q̇) q̇_F, NF (N·m or N).",
        quote!(q: &[f64; #nj_ts], qd: &[f64; NF], p: &[f64; #np_ts]),
        quote!([f64; NF]),
        &cqd,
        &qqdp_inp,
        (nf, 0),
        &mut ops,
    )?);
    items.push(kernel(
        sm,
        "gravity",
        "Gravity torques φ_F(q) (thesis 3.4), NF (N·m or N).",
        quote!(q: &[f64; #nj_ts], p: &[f64; #np_ts]),
        quote!([f64; NF]),
        &ex.phi,
        &qp_inp,
        (nf, 0),
        &mut ops,
    )?);
    let tau: Vec<Atom> = (0..nf)
        .map(|a| {
            let mut acc = &cqd[a] + &ex.phi[a];
            for b in 0..nf {
                acc += &ex.d[a][b] * Atom::var(sm.vars.qdd[free[b]]);
            }
            acc
        })
        .collect();
    items.push(kernel(
        sm,
        "inverse_dynamics",
        "Inverse dynamics τ_F = D q̈ + C q̇ + φ (thesis 3.5), NF (N·m or N).",
        quote!(q: &[f64; #nj_ts], qd: &[f64; NF], qdd: &[f64; NF], p: &[f64; #np_ts]),
        quote!([f64; NF]),
        &tau,
        &full_inp,
        (nf, 0),
        &mut ops,
    )?);
    items.push(kernel(
        sm,
        "regressor",
        "Regressor Y_F(q, q̇, q̈) with τ_F = Y_F p, NF × NP.",
        quote!(q: &[f64; #nj_ts], qd: &[f64; NF], qdd: &[f64; NF]),
        quote!([[f64; #np_ts]; NF]),
        &flat(&ex.y),
        &y_inp,
        (nf, sm.params.len()),
        &mut ops,
    )?);
    // Forward dynamics: D and h = C q̇ + φ in one evaluator, then Cholesky.
    let mut dh: Vec<Atom> = Vec::new();
    for a in 0..nf {
        for b in 0..=a {
            dh.push(ex.d[a][b].clone());
        }
    }
    for a in 0..nf {
        dh.push(&cqd[a] + &ex.phi[a]);
    }
    let (stmts, results, o) = straight_line(&dh, &qqdp_inp.atoms, &qqdp_inp.tokens, "")?;
    let pre = trig_prelude(sm, &dh);
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
    let mut fo = o;
    fo.add += nf * nf * (nf + 1) / 2 + nf; // Cholesky + solves, approximately
    fo.mul += nf * nf * (nf + 1) / 2;
    fo.other += nf * 3;
    ops.push(("forward_dynamics".into(), fo));
    items.push(quote! {
        /// Forward dynamics q̈_F = D_FF⁻¹ (τ_F − C q̇ − φ) by an unrolled Cholesky
        /// factorisation, NF (rad/s² or m/s²). NaN when D_FF is not positive definite.
        #[inline]
        pub fn forward_dynamics(q: &[f64; #nj_ts], qd: &[f64; NF], tau: &[f64; NF], p: &[f64; #np_ts]) -> [f64; NF] {
            #(#pre)*
            #(#stmts)*
            let d: [[f64; NF]; NF] = [#(#d_full),*];
            let rhs: [f64; NF] = [#(#rhs),*];
            #chol
        }
    });
    let present: Vec<String> = ex
        .present
        .iter()
        .map(|&j| sm.params[j].name.clone())
        .collect();
    let present_idx: Vec<proc_macro2::Literal> = ex
        .present
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
            #(#items)*

            pub(crate) fn mass_matrix_dyn(q: &[f64], p: &[f64], out: &mut [f64]) {
                let m = mass_matrix(q.try_into().unwrap(), p.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
            }
            pub(crate) fn christoffel_matrix_dyn(q: &[f64], qd: &[f64], p: &[f64], out: &mut [f64]) {
                let m = christoffel_matrix(q.try_into().unwrap(), qd.try_into().unwrap(), p.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
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
            pub(crate) fn regressor_dyn(q: &[f64], qd: &[f64], qdd: &[f64], out: &mut [f64]) {
                let m = regressor(q.try_into().unwrap(), qd.try_into().unwrap(), qdd.try_into().unwrap());
                out.copy_from_slice(m.as_flattened());
            }
            pub(crate) const CONFIGURATION: crate::Configuration = crate::Configuration {
                name: #cname,
                free: &FREE,
                params_present: PARAMS_PRESENT,
                mass_matrix: mass_matrix_dyn,
                christoffel_matrix: christoffel_matrix_dyn,
                gravity: gravity_dyn,
                inverse_dynamics: inverse_dynamics_dyn,
                forward_dynamics: forward_dynamics_dyn,
                regressor: regressor_dyn,
            };
        }
    };
    let report = ConfigReport {
        name: conf.name.clone(),
        free: free_names,
        params_present: present,
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
    let sym_atoms: Vec<Atom> = model
        .inertial_symbols
        .iter()
        .map(|(s, _)| Atom::var(user_symbol(s)))
        .collect();
    let sym_tokens: Vec<TokenStream> = (0..sym_atoms.len())
        .map(|i| {
            let i = proc_macro2::Literal::usize_unsuffixed(i);
            quote!(u[#i])
        })
        .collect();
    let bary_exprs: Vec<Atom> = sm.params.iter().map(|b| b.expr.clone()).collect();
    let (bstmts, bres, _) = straight_line(&bary_exprs, &sym_atoms, &sym_tokens, "")?;
    let nj = model.joints.len();
    let np = sm.params.len();
    let ni = sym_atoms.len();
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
        .map(|(s, _)| s.as_str())
        .collect();
    let mname = &model.name;
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
            barycentric_from_symbols: barycentric_from_symbols_dyn,
            configurations: &[#(#conf_idents::CONFIGURATION),*],
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
