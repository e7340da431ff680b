//! A per-system profile built from tracing spans, like pbrt's "Wavefront Kernel Profile".
//!
//! bevy_ecs (with the `trace` feature) runs every system inside a span named `system` whose `name`
//! field is the system's path, created once per system and entered once per run, with `parent: None`.
//! [`SystemProfileLayer`] records that field when the span is created and sums the time between
//! enter and exit by name. The library never installs a subscriber; the binary adds this layer for
//! `--profile`, and [`span_label`] names spans in a Chrome trace.

use caustica::trace::TraversalTotals;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tracing::span::{Attributes, Id};
use tracing::{Subscriber, field};
use tracing_subscriber::layer::{Context, Layer};
use tracing_subscriber::registry::{LookupSpan, SpanRef};

/// The `name` field of a span, kept in its extensions.
#[derive(Clone, Debug)]
pub struct SpanField(pub String);

/// When the span was last entered.
struct Entered(Instant);

/// Time spent in one system.
#[derive(Clone, Copy, Debug)]
pub struct SystemTiming {
    /// Runs.
    pub calls: u64,
    /// Total time inside the system.
    pub total: Duration,
    /// Shortest run.
    pub min: Duration,
    /// Longest run.
    pub max: Duration,
}

/// Timings by system name, shared between the layer and whoever prints them.
#[derive(Clone, Debug, Default)]
pub struct SystemProfile {
    timings: Arc<Mutex<BTreeMap<String, SystemTiming>>>,
}

/// The tracing layer that fills a [`SystemProfile`].
#[derive(Clone, Debug)]
pub struct SystemProfileLayer {
    profile: SystemProfile,
}

impl SystemProfile {
    /// A layer that adds to this profile.
    pub fn layer(&self) -> SystemProfileLayer {
        SystemProfileLayer { profile: self.clone() }
    }

    /// The timings so far, by system name.
    pub fn timings(&self) -> BTreeMap<String, SystemTiming> {
        self.timings.lock().map(|t| t.clone()).unwrap_or_default()
    }

    /// A table: system, calls, total ms, % of the systems' total, mean, min and max ms; slowest first.
    pub fn table(&self) -> String {
        let timings = self.timings();
        let all: f64 = timings.values().map(|t| t.total.as_secs_f64()).sum();
        let mut rows: Vec<_> = timings.into_iter().collect();
        rows.sort_by_key(|row| std::cmp::Reverse(row.1.total));
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let mut out = format!(
            "{:<44} {:>8} {:>11} {:>6} {:>9} {:>9} {:>9}\n",
            "system", "calls", "total ms", "%", "mean ms", "min ms", "max ms"
        );
        for (name, t) in rows {
            let _ = writeln!(
                out,
                "{:<44} {:>8} {:>11.2} {:>6.1} {:>9.3} {:>9.3} {:>9.3}",
                short_name(&name),
                t.calls,
                ms(t.total),
                100.0 * t.total.as_secs_f64() / all.max(1e-12),
                ms(t.total) / t.calls.max(1) as f64,
                ms(t.min),
                ms(t.max)
            );
        }
        let _ = writeln!(out, "{:<44} {:>8} {:>11.2}", "all systems", "", all * 1e3);
        out
    }
}

impl SystemProfile {
    /// A table of the trace stages that ran: rays, millions of rays a second of the stage's wall time
    /// (all threads together; counting itself costs a few percent), and BVH nodes and leaves a ray visited.
    pub fn trace_table(&self, totals: &[(&str, TraversalTotals)]) -> String {
        let timings = self.timings();
        let mut out = format!(
            "{:<44} {:>12} {:>12} {:>10} {:>10}\n",
            "stage", "rays", "M rays/s", "nodes/ray", "leaves/ray"
        );
        for (stage, totals) in totals.iter().filter(|(_, t)| t.rays > 0) {
            let seconds: f64 = timings
                .iter()
                .filter(|(name, _)| short_name(name) == *stage)
                .map(|(_, t)| t.total.as_secs_f64())
                .sum();
            let (nodes, leaves) = totals.per_ray();
            let rate =
                if seconds > 0.0 { format!("{:.2}", totals.rays as f64 / seconds / 1e6) } else { "-".into() };
            let _ = writeln!(out, "{stage:<44} {:>12} {rate:>12} {nodes:>10.2} {leaves:>10.2}", totals.rays);
        }
        out
    }
}

/// `caustica::trace::trace_paths` → `trace_paths`; generic arguments are kept
/// (`emit_camera_paths<false, false>`), since each instance is its own system.
pub fn short_name(path: &str) -> &str {
    let head = path.find('<').unwrap_or(path.len());
    let start = path[..head].rfind("::").map_or(0, |i| i + 2);
    &path[start..]
}

struct NameVisitor(Option<String>);

impl field::Visit for NameVisitor {
    fn record_str(&mut self, f: &field::Field, value: &str) {
        if f.name() == "name" {
            self.0 = Some(value.to_owned());
        }
    }

    fn record_debug(&mut self, f: &field::Field, value: &dyn std::fmt::Debug) {
        if f.name() == "name" {
            self.0 = Some(format!("{value:?}"));
        }
    }
}

impl<S: Subscriber + for<'a> LookupSpan<'a>> Layer<S> for SystemProfileLayer {
    fn on_new_span(&self, attrs: &Attributes<'_>, id: &Id, ctx: Context<'_, S>) {
        let mut visitor = NameVisitor(None);
        attrs.record(&mut visitor);
        if let (Some(name), Some(span)) = (visitor.0, ctx.span(id)) {
            span.extensions_mut().insert(SpanField(name));
        }
    }

    fn on_enter(&self, id: &Id, ctx: Context<'_, S>) {
        if let Some(span) = ctx.span(id).filter(|s| s.name() == "system") {
            span.extensions_mut().replace(Entered(Instant::now()));
        }
    }

    fn on_exit(&self, id: &Id, ctx: Context<'_, S>) {
        let Some(span) = ctx.span(id).filter(|s| s.name() == "system") else {
            return;
        };
        let extensions = span.extensions();
        let (Some(name), Some(entered)) = (extensions.get::<SpanField>(), extensions.get::<Entered>()) else {
            return;
        };
        let elapsed = entered.0.elapsed();
        if let Ok(mut timings) = self.profile.timings.lock() {
            let t = timings.entry(name.0.clone()).or_insert(SystemTiming {
                calls: 0,
                total: Duration::ZERO,
                min: Duration::MAX,
                max: Duration::ZERO,
            });
            t.calls += 1;
            t.total += elapsed;
            t.min = t.min.min(elapsed);
            t.max = t.max.max(elapsed);
        }
    }
}

/// A span's label for a Chrome trace: `system: trace_paths` for a system, else the span's name
/// with its `name` field when it has one (as bevy_log does).
pub fn span_label<S: for<'a> LookupSpan<'a>>(span: &SpanRef<'_, S>) -> String {
    match span.extensions().get::<SpanField>() {
        Some(field) => format!("{}: {}", span.name(), short_name(&field.0)),
        None => span.name().to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_names_drop_the_module_path_but_keep_generics() {
        assert_eq!(short_name("caustica::trace::trace_paths"), "trace_paths");
        assert_eq!(
            short_name("caustica::emit::emit_camera_paths<false, true>"),
            "emit_camera_paths<false, true>"
        );
        assert_eq!(short_name("plain"), "plain");
    }
}
