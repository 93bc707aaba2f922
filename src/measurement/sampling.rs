//! Real logs as they come: a record's sample times made even before anything uses them.
//!
//! A logger on a real arm writes rows at jittered times (a non-real-time process), writes a
//! row twice (the same time and values), or writes the last values again at later times
//! while the bus delivers nothing new (stale rows). [`Table::read`] hands every command a
//! table whose times are evenly spaced, and says what it did in [`Table::notes`] (each note
//! naming the file):
//! - an exact repeat of the row before (same time, same values) is dropped;
//! - stale rows (later time, every other column equal to the row before): a run of at most
//!   [`LARGEST_GAP`] rows is a logger's glitch, its values interpolated in time between the
//!   fresh rows around it (left as they are, a held position puts a step into the
//!   trajectory and spikes into its derivatives: on the EMPS record three stale rows moved
//!   the IDIM mass by 4 standard errors); a longer run is a pause, kept; both reported;
//! - uneven steps (a step off the median period by more than [`EVEN_TOLERANCE`]) are
//!   resampled onto the median period from the first time to the last, each column by
//!   linear interpolation between the two samples around each new time (error ≤ h²/8·|x″|
//!   for a period h; the rate stays the same, so nothing folds down from above Nyquist), and
//!   the jitter is reported;
//! - a gap of more than [`LARGEST_GAP`] median periods is missing data, not jitter: refused,
//!   naming the rows.
//!
//! Time that goes backwards, or a repeated time with other values, is left for
//! `check_sampling` to refuse with its row.

use super::*;

/// Largest relative deviation of a step from the median period for a record to count as
/// evenly sampled (as `check_sampling` requires).
pub const EVEN_TOLERANCE: f64 = 1e-3;

/// Largest step, in median periods, that resampling bridges; a longer one is a gap of
/// missing samples.
pub const LARGEST_GAP: f64 = 3.0;

impl Table {
    /// Make the times even ([module docs](self)): drop exact repeats, report stale rows,
    /// resample uneven times onto the median period. A table without a numeric `t`, or
    /// with fewer than two rows, is left as it is (the column's use reports it).
    ///
    /// # Errors
    /// [`DataError::Record`]: a gap of more than [`LARGEST_GAP`] median periods, naming
    /// its rows.
    pub(super) fn regularise(&mut self) -> Result<(), DataError> {
        let Some(ti) = self.names.iter().position(|n| n == "t") else {
            return Ok(());
        };
        let Ok(t) = self.columns[ti].clone() else {
            return Ok(());
        };
        if t.len() < 2 {
            return Ok(());
        }
        let others: Vec<usize> = (0..self.columns.len())
            .filter(|&i| i != ti && self.columns[i].is_ok())
            .collect();
        let same_values = |k: usize| {
            others.iter().all(|&i| match &self.columns[i] {
                Ok(c) => c[k] == c[k - 1],
                Err(_) => true,
            })
        };
        // Rows as the file numbers them: the header is line 1 of a CSV.
        let row = |k: usize| k + 2;
        // Time that does not increase with other values: check_sampling refuses it.
        if (1..t.len()).any(|k| t[k] < t[k - 1] || (t[k] == t[k - 1] && !same_values(k))) {
            return Ok(());
        }
        let repeats: Vec<usize> = (1..t.len())
            .filter(|&k| t[k] == t[k - 1] && same_values(k))
            .collect();
        let stale: Vec<usize> = (1..t.len())
            .filter(|&k| t[k] > t[k - 1] && !others.is_empty() && same_values(k))
            .collect();
        // Short stale runs are a logger's glitch: their values are the fresh rows' around
        // them, interpolated in time (left as they are they put a step into the position and
        // spikes into its derivatives). Longer runs are a pause, kept.
        let (mut glitches, mut pauses) = (Vec::new(), Vec::new());
        for run in contiguous(&stale) {
            let (first, last) = (run[0], run[run.len() - 1]);
            if run.len() as f64 <= LARGEST_GAP && last + 1 < t.len() {
                for &i in &others {
                    if let Ok(c) = &mut self.columns[i] {
                        let (a, b) = (first - 1, last + 1);
                        for k in first..=last {
                            let w = (t[k] - t[a]) / (t[b] - t[a]);
                            c[k] = c[a] + w * (c[b] - c[a]);
                        }
                    }
                }
                glitches.extend(run.iter().map(|&k| row(k)));
            } else {
                pauses.extend(run.iter().map(|&k| row(k)));
            }
        }
        if !glitches.is_empty() {
            self.notes.push(format!(
                "{}: {} stale row(s) (the values of the row before again, at a later time): {}; values interpolated between the fresh rows around them",
                self.file.display(),
                glitches.len(),
                runs(&glitches)
            ));
        }
        if !pauses.is_empty() {
            self.notes.push(format!(
                "{}: {} row(s) repeat the values of the row before for more than {LARGEST_GAP} rows (a pause, or a stale logger): {}; kept",
                self.file.display(),
                pauses.len(),
                runs(&pauses)
            ));
        }
        if !repeats.is_empty() {
            self.notes.push(format!(
                "{}: {} exact repeat(s) of the row before (same time, same values) dropped: {}",
                self.file.display(),
                repeats.len(),
                runs(&repeats.iter().map(|&k| row(k)).collect::<Vec<_>>())
            ));
            let keep: Vec<bool> = (0..t.len()).map(|k| !repeats.contains(&k)).collect();
            for c in self.columns.iter_mut().flatten() {
                *c = c
                    .iter()
                    .zip(&keep)
                    .filter_map(|(x, &k)| k.then_some(*x))
                    .collect();
            }
        }
        let Ok(t) = self.columns[ti].clone() else {
            return Ok(());
        };
        if t.len() < 2 {
            return Ok(());
        }
        let steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        let h = median(&steps);
        if steps.iter().all(|s| (s - h).abs() <= EVEN_TOLERANCE * h) {
            return Ok(());
        }
        if let Some(k) = steps.iter().position(|&s| s > LARGEST_GAP * h) {
            return Err(DataError::Record {
                file: self.file.clone(),
                reason: format!(
                    "time {} s to {} s: a gap of {:.3e} s, {:.1} median periods ({h:.6e} s): samples are missing; split the record there",
                    t[k],
                    t[k + 1],
                    steps[k],
                    steps[k] / h
                ),
            });
        }
        let (smallest, largest) = steps
            .iter()
            .fold((f64::INFINITY, 0.0_f64), |(a, b), &s| (a.min(s), b.max(s)));
        let n = ((t[t.len() - 1] - t[0]) / h + 1e-9).floor() as usize + 1;
        let grid: Vec<f64> = (0..n).map(|k| t[0] + k as f64 * h).collect();
        for (i, c) in self.columns.iter_mut().enumerate() {
            if let Ok(c) = c {
                *c = if i == ti {
                    grid.clone()
                } else {
                    linear_at(&t, c, &grid)
                };
            }
        }
        self.notes.push(format!(
            "{}: uneven sampling: steps {smallest:.4e} to {largest:.4e} s, jitter {:.0} % of the median period {h:.6e} s; resampled onto that period by linear interpolation ({} rows to {n})",
            self.file.display(),
            100.0 * (largest - h).max(h - smallest) / h,
            t.len()
        ));
        Ok(())
    }
}

/// The median of `x` (not empty).
fn median(x: &[f64]) -> f64 {
    let mut s = x.to_vec();
    s.sort_by(f64::total_cmp);
    let m = s.len() / 2;
    if s.len() % 2 == 1 {
        s[m]
    } else {
        0.5 * (s[m - 1] + s[m])
    }
}

/// The samples `x` at times `t` (increasing) linearly interpolated at `at` (within
/// [t₀, t_last]).
fn linear_at(t: &[f64], x: &[f64], at: &[f64]) -> Vec<f64> {
    let mut k = 0;
    at.iter()
        .map(|&s| {
            while k + 2 < t.len() && t[k + 1] < s {
                k += 1;
            }
            let w = ((s - t[k]) / (t[k + 1] - t[k])).clamp(0.0, 1.0);
            x[k] + w * (x[k + 1] - x[k])
        })
        .collect()
}

/// Increasing indices split into runs of consecutive ones.
fn contiguous(k: &[usize]) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    for &i in k {
        match out.last_mut() {
            Some(run) if run[run.len() - 1] + 1 == i => run.push(i),
            _ => out.push(vec![i]),
        }
    }
    out
}

/// Row numbers as runs, e.g. "rows 5–8, 12".
fn runs(rows: &[usize]) -> String {
    let mut parts = Vec::new();
    let mut i = 0;
    while i < rows.len() {
        let mut j = i;
        while j + 1 < rows.len() && rows[j + 1] == rows[j] + 1 {
            j += 1;
        }
        parts.push(if j > i {
            format!("{}–{}", rows[i], rows[j])
        } else {
            rows[i].to_string()
        });
        i = j + 1;
    }
    let more = parts.len() > 8;
    parts.truncate(8);
    format!(
        "row{} {}{}",
        if rows.len() > 1 { "s" } else { "" },
        parts.join(", "),
        if more { ", …" } else { "" }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(t: Vec<f64>, x: Vec<f64>) -> Table {
        Table {
            file: PathBuf::from("log.csv"),
            side: SideFile::default(),
            names: vec!["t".into(), "q0".into()],
            columns: vec![Ok(t), Ok(x)],
            what: "column",
            notes: Vec::new(),
        }
    }

    /// ±30 % jitter (uniform, seeded) on a 1 kHz log of a line: resampled onto the median
    /// period, evenly, with the line's values exactly (a line is interpolated without error),
    /// the jitter reported.
    #[test]
    fn jittered_times_are_resampled_onto_the_median_period() {
        let n = 2000;
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let t: Vec<f64> = (0..n)
            .map(|k| {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                let r = (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
                let jitter = if k == 0 || k == n - 1 { 0.0 } else { 0.3 * r };
                (k as f64 + jitter) * 1e-3
            })
            .collect();
        let x: Vec<f64> = t.iter().map(|s| 2.0 + 3.0 * s).collect();
        let mut tb = table(t, x);
        tb.regularise().unwrap();
        let t = tb.need("t").unwrap();
        let x = tb.need("q0").unwrap();
        let h = check_sampling(Path::new("log.csv"), &t).unwrap();
        // The median of the steps is the period to within its sampling error.
        assert!((h - 1e-3).abs() < 2e-5, "{h}");
        assert!(t.len().abs_diff(n) <= n / 50, "{}", t.len());
        for (k, (s, v)) in t.iter().zip(&x).enumerate() {
            assert!((v - (2.0 + 3.0 * s)).abs() < 1e-12, "{k}");
        }
        assert!(
            tb.notes[0].contains("uneven sampling") && tb.notes[0].contains("resampled"),
            "{:?}",
            tb.notes
        );
    }

    /// Exact repeats are dropped, stale rows kept and reported with their rows, a gap is
    /// refused naming its times.
    #[test]
    fn repeats_are_dropped_stale_rows_reported_and_gaps_refused() {
        let t = vec![0.0, 0.01, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06];
        let x = vec![1.0, 2.0, 2.0, 3.0, 3.0, 3.0, 6.0, 7.0];
        let mut tb = table(t, x);
        tb.regularise().unwrap();
        assert_eq!(
            tb.need("t").unwrap(),
            vec![0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06]
        );
        // The stale run (rows 6–7) interpolated between rows 5 and 8.
        let q = tb.need("q0").unwrap();
        for (a, b) in q.iter().zip([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]) {
            assert!((a - b).abs() < 1e-12, "{q:?}");
        }
        let notes = tb.notes.join(" | ");
        assert!(
            notes.contains("exact repeat") && notes.contains("row 4"),
            "{notes}"
        );
        assert!(
            notes.contains("2 stale row(s)")
                && notes.contains("rows 6–7")
                && notes.contains("interpolated"),
            "{notes}"
        );
        // A long run is a pause: kept.
        let mut pause = table(
            (0..12).map(|k| k as f64 * 0.01).collect(),
            vec![0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
        );
        pause.regularise().unwrap();
        assert_eq!(pause.need("q0").unwrap()[3], 1.0);
        assert!(
            pause.notes[0].contains("a pause") && pause.notes[0].contains("rows 4–8"),
            "{:?}",
            pause.notes
        );
        let mut gap = table(
            vec![0.0, 0.01, 0.02, 0.07, 0.08],
            vec![0.0, 1.0, 2.0, 3.0, 4.0],
        );
        let e = gap.regularise().unwrap_err().to_string();
        assert!(
            e.contains("log.csv") && e.contains("0.02 s to 0.07 s"),
            "{e}"
        );
        // Time that goes back is left to check_sampling, which names the row.
        let mut t: Vec<f64> = (0..12).map(|k| k as f64 * 0.01).collect();
        t[2] = 0.005;
        let mut back = table(t, (0..12).map(f64::from).collect());
        back.regularise().unwrap();
        let e = check_sampling(Path::new("log.csv"), &back.need("t").unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 4"), "{e}");
    }

    #[test]
    fn linear_interpolation_hits_the_samples_and_the_midpoints() {
        let t = [0.0, 1.0, 3.0];
        let x = [0.0, 2.0, 6.0];
        assert_eq!(
            linear_at(&t, &x, &[0.0, 0.5, 1.0, 2.0, 3.0]),
            vec![0.0, 1.0, 2.0, 4.0, 6.0]
        );
        assert_eq!(runs(&[3, 4, 5, 9]), "rows 3–5, 9");
    }
}
