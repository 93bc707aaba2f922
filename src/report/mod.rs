//! Reporting: tables for the terminal and Markdown, figures ([`plot`]), the wall and
//! closed-loop reports ([`control`]), the model-versus-measurement loop and its HTML report
//! ([`diagnosis`]), the locking sequences' report ([`sequence`]).
pub mod control;
pub mod diagnosis;
pub mod plot;
pub mod sequence;

use crate::identify::idim::Fit;

/// The parameter table of a least-squares fit: name, value, σ, relative σ.
pub fn fit_table(fit: &Fit) -> String {
    let mut s = format!(
        "{:<12} {:>14} {:>12} {:>8}\n",
        "parameter", "value", "std dev", "rel %"
    );
    for i in 0..fit.names.len() {
        s.push_str(&format!(
            "{:<12} {:>14.6} {:>12.4e} {:>8.3}\n",
            fit.names[i],
            fit.theta[i],
            fit.std[i],
            fit.relative_std(i)
        ));
    }
    s.push_str(&format!(
        "rows {}, condition number {:.2}, relative error {:.3} %\n",
        fit.rows, fit.condition, fit.relative_error
    ));
    if !fit.base.is_empty() {
        let folded = fit.std.iter().filter(|s| s.is_nan()).count();
        s.push_str(&format!(
            "the regressor is rank-deficient: {} base parameters fitted; {folded} parameter(s) not separately identifiable keep the plant's values (std dev NaN) and are folded into:\n",
            fit.std.len() - folded
        ));
        for b in &fit.base {
            s.push_str(&format!(
                "  {} = {:.6} ± {:.4e}\n",
                b.parameter, b.value, b.std
            ));
        }
    }
    s
}
