//! Straight-line Rust from Symbolica's optimised evaluator (Horner schemes and common
//! subexpression elimination): every instruction becomes one `let` binding, shadowing the
//! previous value of its slot, so the emitted code is branch-free and allocation-free.

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;
use symbolica::atom::{Atom, AtomCore};
use symbolica::evaluate::{Instruction, Slot};

/// Operation counts of emitted code (additions include subtractions).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Ops {
    /// Additions and subtractions.
    pub add: usize,
    /// Multiplications (a square counts one).
    pub mul: usize,
    /// Divisions and other calls (powi, sqrt).
    pub other: usize,
}

impl Ops {
    /// Total operation count.
    pub fn total(&self) -> usize {
        self.add + self.mul + self.other
    }
}

impl std::ops::AddAssign for Ops {
    fn add_assign(&mut self, o: Ops) {
        self.add += o.add;
        self.mul += o.mul;
        self.other += o.other;
    }
}

/// An error while building or translating an evaluator.
#[derive(Debug, Clone)]
pub struct EmitError(pub String);

impl std::fmt::Display for EmitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Straight-line statements computing `outputs` from `params`.
///
/// `param_tokens[i]` is the Rust expression of evaluator input `i`; the function returns the
/// statements and one expression per output (an identifier or a literal).
///
/// # Errors
/// When Symbolica cannot build the evaluator or emits a branch or an unknown function.
pub fn straight_line(
    outputs: &[Atom],
    params: &[Atom],
    param_tokens: &[TokenStream],
    prefix: &str,
) -> Result<(Vec<TokenStream>, Vec<TokenStream>, Ops), EmitError> {
    assert_eq!(params.len(), param_tokens.len());
    if outputs.is_empty() {
        return Ok((vec![], vec![], Ops::default()));
    }
    let ev = Atom::evaluator_multiple(outputs, params)
        .cores(1)
        .horner_iterations(10)
        .build()
        .map_err(|e| EmitError(format!("evaluator: {e:?}")))?
        .map_coeff(&|c| c.re.to_f64());
    let ex = ev.export_instructions();
    if !ex.sub_evaluators.is_empty() {
        return Err(EmitError("unexpected sub-evaluators".into()));
    }
    let temp = |i: usize| Ident::new(&format!("{prefix}t{i}"), Span::call_site());
    let out = |i: usize| Ident::new(&format!("{prefix}o{i}"), Span::call_site());
    let mut out_written = vec![false; ex.output_count];
    let slot = |s: &Slot, out_written: &[bool]| -> TokenStream {
        match *s {
            Slot::Param(i) => param_tokens[i].clone(),
            Slot::Const(i) => lit(ex.constants[i]),
            Slot::Temp(i) => {
                let id = temp(i);
                quote!(#id)
            }
            Slot::Out(i) => {
                debug_assert!(out_written[i]);
                let id = out(i);
                quote!(#id)
            }
        }
    };
    let target = |s: &Slot, out_written: &mut Vec<bool>| -> Ident {
        match *s {
            Slot::Temp(i) => temp(i),
            Slot::Out(i) => {
                out_written[i] = true;
                out(i)
            }
            _ => unreachable!("evaluator writes to a parameter or a constant"),
        }
    };
    let mut stmts = Vec::new();
    let mut ops = Ops::default();
    for ins in &ex.instructions {
        match ins {
            Instruction::Add(o, args, _) => {
                let mut terms = args.iter().map(|a| slot(a, &out_written));
                let first = terms.next().unwrap_or_else(|| quote!(0.0));
                let rest: Vec<TokenStream> = terms.collect();
                ops.add += rest.len();
                let t = target(o, &mut out_written);
                stmts.push(quote!(let #t = #first #(+ #rest)*;));
            }
            Instruction::Mul(o, args, _) => {
                // A factor −1 becomes a negation.
                let mut neg = false;
                let mut factors = Vec::new();
                for a in args {
                    if let Slot::Const(i) = a {
                        if ex.constants[*i] == -1.0 {
                            neg = !neg;
                            continue;
                        }
                    }
                    factors.push(slot(a, &out_written));
                }
                ops.mul += factors.len().saturating_sub(1);
                let t = target(o, &mut out_written);
                let first = factors.first().cloned().unwrap_or_else(|| quote!(1.0));
                let rest = &factors[1.min(factors.len())..];
                if neg {
                    stmts.push(quote!(let #t = -(#first #(* #rest)*);));
                } else {
                    stmts.push(quote!(let #t = #first #(* #rest)*;));
                }
            }
            Instruction::Pow(o, b, e, _) => {
                let b = slot(b, &out_written);
                let t = target(o, &mut out_written);
                let e = *e;
                let st = match e {
                    -1 => {
                        ops.other += 1;
                        quote!(let #t = 1.0 / #b;)
                    }
                    2 => {
                        ops.mul += 1;
                        quote!(let #t = #b * #b;)
                    }
                    3 => {
                        ops.mul += 2;
                        quote!(let #t = #b * #b * #b;)
                    }
                    _ => {
                        ops.other += 1;
                        let e = Literal::i32_unsuffixed(e as i32);
                        quote!(let #t = (#b).powi(#e);)
                    }
                };
                stmts.push(st);
            }
            Instruction::Assign(o, v) => {
                let v = slot(v, &out_written);
                let t = target(o, &mut out_written);
                stmts.push(quote!(let #t = #v;));
            }
            other => {
                return Err(EmitError(format!(
                    "unsupported evaluator instruction in straight-line code: {other:?}"
                )))
            }
        }
    }
    let results = (0..ex.output_count)
        .map(|i| {
            if out_written[i] {
                let id = out(i);
                quote!(#id)
            } else {
                quote!(0.0)
            }
        })
        .collect();
    Ok((stmts, results, ops))
}

/// An f64 literal token (exact round trip).
pub fn lit(v: f64) -> TokenStream {
    if v < 0.0 {
        let l = Literal::f64_unsuffixed(-v);
        quote!((-#l))
    } else {
        let l = Literal::f64_unsuffixed(v);
        quote!(#l)
    }
}
