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
    Ok(data)
}
