//! Small shared helpers: TOML errors with line numbers, configuration lookup.

use anyhow::{Context, Result};
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Write to standard output; once the reader has gone (a closed pipe: `lockstep models |
/// head -1`), further output is dropped quietly and the command goes on to write its files
/// and exit 0, as coreutils do for a closed pipe. Used through [`out!`](crate::out) and
/// [`outln!`](crate::outln).
pub fn print_stdout(args: std::fmt::Arguments) {
    if STDOUT_CLOSED.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    if out.write_fmt(args).and_then(|_| out.flush()).is_err() {
        STDOUT_CLOSED.store(true, Ordering::Relaxed);
    }
}

/// Write to standard error, ignoring a closed stream (warnings and progress).
pub fn print_stderr(args: std::fmt::Arguments) {
    let _ = std::io::stderr().lock().write_fmt(args);
}

/// `print!` that survives a closed pipe ([`util::print_stdout`](crate::util::print_stdout)).
#[macro_export]
macro_rules! out {
    ($($t:tt)*) => { $crate::util::print_stdout(format_args!($($t)*)) };
}

/// `println!` that survives a closed pipe ([`util::print_stdout`](crate::util::print_stdout)).
#[macro_export]
macro_rules! outln {
    () => { $crate::util::print_stdout(format_args!("\n")) };
    ($($t:tt)*) => { $crate::util::print_stdout(format_args!("{}\n", format_args!($($t)*))) };
}

/// `eprintln!` that survives a closed stream, for warnings and notes (stdout carries
/// results only).
#[macro_export]
macro_rules! errln {
    ($($t:tt)*) => { $crate::util::print_stderr(format_args!("{}\n", format_args!($($t)*))) };
}

/// Refuse a computation that would need about `bytes` of memory when that is more than half
/// of the memory available (Linux `MemAvailable`; elsewhere 8 GiB is assumed), or more
/// than 64 GiB: a clear message instead of an allocation failure (abort).
///
/// # Errors
/// Too large; `what` names the argument that sets the size.
pub fn check_memory(bytes: f64, what: &str) -> Result<()> {
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(8.0 * (1u64 << 30) as f64, |kib| kib * 1024.0);
    let limit = (available / 2.0).min(64.0 * (1u64 << 30) as f64);
    if bytes.is_nan() || bytes > limit {
        anyhow::bail!(
            "{what}: would need about {:.1} GiB of memory, more than the {:.1} GiB this command allows itself (half of what is available); shorten it",
            bytes / (1u64 << 30) as f64,
            limit / (1u64 << 30) as f64
        );
    }
    Ok(())
}

/// Singular value decomposition (U and Vᵀ computed) that can neither hang nor panic: `None`
/// when `a` holds a non-finite entry or the iteration does not converge. nalgebra's `svd`
/// iterates forever on a NaN or infinite entry and panics sorting NaN singular values;
/// every least-squares solve of lockstep goes through here.
pub fn svd(a: nalgebra::DMatrix<f64>) -> Option<nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>> {
    guarded_svd(a, true)
}

/// Singular values only, under the same guards as [`svd`].
pub fn singular_values(a: &nalgebra::DMatrix<f64>) -> Option<nalgebra::DVector<f64>> {
    guarded_svd(a.clone(), false).map(|s| s.singular_values)
}

/// [`svd`]'s guards: finite entries, a bounded number of iterations, finite singular values
/// and vectors.
fn guarded_svd(
    a: nalgebra::DMatrix<f64>,
    vectors: bool,
) -> Option<nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>> {
    if !a.iter().all(|x| x.is_finite()) {
        return None;
    }
    let limit = 1000 + 100 * a.nrows().min(a.ncols());
    let svd = a.try_svd(vectors, vectors, f64::EPSILON, limit)?;
    // A decomposition with a non-finite singular vector or value is no decomposition.
    let finite = |m: &Option<nalgebra::DMatrix<f64>>| {
        m.as_ref().is_none_or(|m| m.iter().all(|x| x.is_finite()))
    };
    (svd.singular_values.iter().all(|x| x.is_finite()) && finite(&svd.u) && finite(&svd.v_t))
        .then_some(svd)
}

/// A TOML parse error as one line: `origin: line N: message`.
pub fn toml_error(origin: &str, text: &str, e: &toml::de::Error) -> anyhow::Error {
    let line = e
        .span()
        .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
    anyhow::anyhow!(
        "{origin}{}: {}",
        line.map(|l| format!(": line {l}")).unwrap_or_default(),
        e.message().replace('`', "'")
    )
}

/// A generated model by name.
///
/// # Errors
/// Unknown name (the generated models are listed).
pub fn model(name: &str) -> Result<&'static generated::Model> {
    generated::model(name).with_context(|| {
        format!(
            "unknown model '{name}' (generated models: {})",
            generated::MODELS
                .iter()
                .map(|m| m.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

/// A configuration of `model` by name.
///
/// # Errors
/// Unknown name (the model's configurations are listed).
pub fn configuration(
    model: &'static generated::Model,
    name: &str,
) -> Result<&'static generated::Configuration> {
    model.configuration(name).with_context(|| {
        format!(
            "model '{}' has no configuration '{name}' (it has {})",
            model.name,
            model
                .configurations
                .iter()
                .map(|c| c.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

/// Read JSON that lockstep wrote back into `T`, with `null` accepted wherever a number is
/// expected and read as NaN: serde_json writes NaN and ±∞ (an undetermined standard error,
/// an infinite condition number) as `null`, which plain deserialisation refuses.
///
/// # Errors
/// Not JSON, or not the shape of `T`.
pub fn from_json_with_nan<T: serde::de::DeserializeOwned>(text: &str) -> serde_json::Result<T> {
    let v: serde_json::Value = serde_json::from_str(text)?;
    T::deserialize(NanAsNull(v))
}

/// A JSON value whose `null`s deserialise as NaN where a float is expected.
struct NanAsNull(serde_json::Value);

impl<'de> serde::Deserializer<'de> for NanAsNull {
    type Error = serde_json::Error;

    fn deserialize_any<V: serde::de::Visitor<'de>>(self, v: V) -> serde_json::Result<V::Value> {
        use serde_json::Value;
        match self.0 {
            Value::Array(a) => v.visit_seq(NanSeq(a.into_iter())),
            Value::Object(m) => v.visit_map(NanMap(m.into_iter(), None)),
            other => other.deserialize_any(v),
        }
    }

    fn deserialize_f64<V: serde::de::Visitor<'de>>(self, v: V) -> serde_json::Result<V::Value> {
        match self.0 {
            serde_json::Value::Null => v.visit_f64(f64::NAN),
            other => other.deserialize_f64(v),
        }
    }

    fn deserialize_f32<V: serde::de::Visitor<'de>>(self, v: V) -> serde_json::Result<V::Value> {
        self.deserialize_f64(v)
    }

    fn deserialize_option<V: serde::de::Visitor<'de>>(self, v: V) -> serde_json::Result<V::Value> {
        match self.0 {
            serde_json::Value::Null => v.visit_none(),
            other => v.visit_some(NanAsNull(other)),
        }
    }

    fn deserialize_newtype_struct<V: serde::de::Visitor<'de>>(
        self,
        _name: &'static str,
        v: V,
    ) -> serde_json::Result<V::Value> {
        v.visit_newtype_struct(self)
    }

    fn deserialize_enum<V: serde::de::Visitor<'de>>(
        self,
        name: &'static str,
        variants: &'static [&'static str],
        v: V,
    ) -> serde_json::Result<V::Value> {
        self.0.deserialize_enum(name, variants, v)
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 char str string bytes byte_buf unit
        unit_struct seq tuple tuple_struct map struct identifier ignored_any
    }
}

struct NanSeq(std::vec::IntoIter<serde_json::Value>);

impl<'de> serde::de::SeqAccess<'de> for NanSeq {
    type Error = serde_json::Error;

    fn next_element_seed<S: serde::de::DeserializeSeed<'de>>(
        &mut self,
        seed: S,
    ) -> serde_json::Result<Option<S::Value>> {
        self.0
            .next()
            .map(|x| seed.deserialize(NanAsNull(x)))
            .transpose()
    }
}

struct NanMap(serde_json::map::IntoIter, Option<serde_json::Value>);

impl<'de> serde::de::MapAccess<'de> for NanMap {
    type Error = serde_json::Error;

    fn next_key_seed<K: serde::de::DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> serde_json::Result<Option<K::Value>> {
        match self.0.next() {
            Some((k, v)) => {
                self.1 = Some(v);
                seed.deserialize(serde_json::Value::String(k)).map(Some)
            }
            None => Ok(None),
        }
    }

    fn next_value_seed<S: serde::de::DeserializeSeed<'de>>(
        &mut self,
        seed: S,
    ) -> serde_json::Result<S::Value> {
        let v = self.1.take().unwrap_or(serde_json::Value::Null);
        seed.deserialize(NanAsNull(v))
    }
}

/// NRMSE fit in percent of a simulated or predicted signal against a measured one, as MATLAB's
/// `compare`: 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖), from the sums of squares `sse` = ‖y − ŷ‖² and
/// `sst` = ‖y − ȳ‖² (a constant measurement, `sst` = 0, gives −∞ unless `sse` = 0 too).
pub fn nrmse_fit_from_sums(sse: f64, sst: f64) -> f64 {
    100.0 * (1.0 - (sse / sst.max(1e-300)).sqrt())
}

/// NRMSE fit in percent of `sim` against `meas` ([`nrmse_fit_from_sums`]) over their common
/// length.
pub fn nrmse_fit(meas: &[f64], sim: &[f64]) -> f64 {
    let n = meas.len().min(sim.len());
    let mean = meas[..n].iter().sum::<f64>() / n.max(1) as f64;
    let (mut sse, mut sst) = (0.0, 0.0);
    for k in 0..n {
        sse += (meas[k] - sim[k]).powi(2);
        sst += (meas[k] - mean).powi(2);
    }
    nrmse_fit_from_sums(sse, sst)
}
