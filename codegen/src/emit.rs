//! Shared pieces of code emission: operation counts, errors, f64 literals.

use proc_macro2::{Literal, TokenStream};
use quote::quote;

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

/// An error while generating a model's code (names the model file and the item).
#[derive(Debug, Clone)]
pub struct EmitError(pub String);

impl std::fmt::Display for EmitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
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
