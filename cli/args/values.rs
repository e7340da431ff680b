//! Parsers of flag values: the core's named choices, triples of numbers, part and frame ranges.

use caustica::Choice;

/// A parser for an enum of the core, named as in run files, with each name's help.
pub(super) fn choice<T: Choice + Clone>() -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(T::CHOICES.iter().map(|&(_, name, help)| PossibleValue::new(name).help(help)))
        .map(|name| T::from_name(&name).expect("clap admits only the listed names"))
}

/// Three comma-separated numbers (`1,0.5,2`): a point, vector, colour or set of angles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triple(pub [f32; 3]);

impl std::str::FromStr for Triple {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let values: Vec<f32> = s
            .split(',')
            .map(|v| v.trim().parse::<f32>().map_err(|e| format!("'{v}' is not a number: {e}")))
            .collect::<Result<_, _>>()?;
        match values[..] {
            [x, y, z] if values.iter().all(|v| v.is_finite()) => Ok(Triple([x, y, z])),
            [_, _, _] => Err(format!("'{s}' must be three finite numbers")),
            _ => Err(format!("'{s}' must be three comma-separated numbers, got {}", values.len())),
        }
    }
}

/// `START:END`, END after START.
pub(super) fn parse_frames(text: &str) -> Result<(u32, u32), String> {
    let (start, end) =
        text.split_once(':').ok_or_else(|| format!("{text:?}: expected START:END, as 0:48"))?;
    let number = |s: &str| s.trim().parse::<u32>().map_err(|e| format!("{s:?} in {text:?}: {e}"));
    let (start, end) = (number(start)?, number(end)?);
    if end <= start {
        return Err(format!("{text:?}: END must be after START (END is not rendered)"));
    }
    Ok((start, end))
}

/// `I/K` with 1 ≤ I ≤ K.
pub(super) fn parse_part(text: &str) -> Result<(u32, u32), String> {
    let (i, k) = text.split_once('/').ok_or("expected I/K, as 3/8")?;
    let (i, k): (u32, u32) = (
        i.trim().parse().map_err(|_| format!("'{i}' is not a part number"))?,
        k.trim().parse().map_err(|_| format!("'{k}' is not a number of parts"))?,
    );
    if i == 0 || i > k {
        return Err(format!("part {i} of {k}: need 1 <= I <= K"));
    }
    Ok((i, k))
}

/// `X,Y`: a pixel.
pub(super) fn parse_pixel(text: &str) -> Result<(u32, u32), String> {
    let (x, y) = text.split_once(',').ok_or("expected X,Y, as 128,200")?;
    let number = |s: &str| s.trim().parse::<u32>().map_err(|_| format!("'{s}' is not a pixel coordinate"));
    Ok((number(x)?, number(y)?))
}
