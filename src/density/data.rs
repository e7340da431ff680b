//! Reading a sample of numbers from a text file, for `caustica density` and the tests.

use crate::error::{Error, Result};
use std::path::Path;

/// Whitespace-separated numbers from `path`; an error names the line and the token that is not one.
pub fn read_data(path: &Path) -> Result<Vec<f64>> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.into(), source })?;
    let mut data = Vec::new();
    for (line_no, line) in text.lines().enumerate() {
        for token in line.split(|c: char| c.is_whitespace() || c == ',').filter(|t| !t.is_empty()) {
            let value: f64 = token.parse().map_err(|_| Error::Data {
                path: path.into(),
                message: format!("line {}: '{token}' is not a number", line_no + 1),
            })?;
            if !value.is_finite() {
                return Err(Error::Data {
                    path: path.into(),
                    message: format!("line {}: '{token}' is not finite", line_no + 1),
                });
            }
            data.push(value);
        }
    }
    if data.len() < 2 {
        return Err(Error::Data { path: path.into(), message: "needs at least two numbers".into() });
    }
    // Bandwidths, plots and their axes take differences and squares of the data: they must stay finite.
    let (lo, hi) =
        data.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    if !((hi - lo) * (hi - lo)).is_finite() || !(hi.abs().max(lo.abs()) * 2.0).powi(2).is_finite() {
        return Err(Error::Data {
            path: path.into(),
            message: format!(
                "the numbers span {lo:e} to {hi:e}: too wide for their spread to be computed (keep them within ±1e150)"
            ),
        });
    }
    Ok(data)
}
