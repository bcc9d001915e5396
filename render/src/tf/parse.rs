//! The transfer-function text format, parsed with `nom`.
//!
//! One statement per line; `#` starts a comment; numbers are decimal.
//!
//! ```text
//! # the thesis 'shapes' function
//! domain 0 255             # value range the lookup table covers
//! step 1                   # reference step s0 for the opacities (world units)
//! range 85 95   255 0 0   0.02   # [lo, hi): colour R G B (0-255), opacity
//! range 95 100  0 0 255   0.3
//! point 100     0 255 0   0.6    # control point: value, R G B, opacity
//! point 115     0 255 0   0.0
//! ```
//!
//! Opacity is per unit of world length at the reference step, in `[0, 1]`.
//! Ranges are checked first, in file order; elsewhere the points are
//! interpolated linearly (and held constant past the first and last).

use super::{TfPoint, TfRange, TransferFunction};
use crate::error::RenderError;
use nom::branch::alt;
use nom::bytes::complete::tag;
use nom::character::complete::{space0, space1};
use nom::combinator::{all_consuming, map, opt};
use nom::multi::separated_list1;
use nom::number::complete::float;
use nom::sequence::preceded;
use nom::{IResult, Parser};

enum Statement {
    Domain(f32, f32),
    Step(f32),
    Point(Vec<f32>),
    Range(Vec<f32>),
}

fn numbers(input: &str) -> IResult<&str, Vec<f32>> {
    separated_list1(space1, float).parse(input)
}

fn statement(input: &str) -> IResult<&str, Statement> {
    let keyword_then = |kw: &'static str| preceded((tag(kw), space1), numbers);
    alt((
        map(keyword_then("domain"), |n| {
            Statement::Domain(
                n.first().copied().unwrap_or(f32::NAN),
                *n.get(1).unwrap_or(&f32::NAN),
            )
        }),
        map(keyword_then("step"), |n| Statement::Step(n[0])),
        map(keyword_then("point"), Statement::Point),
        map(keyword_then("range"), Statement::Range),
    ))
    .parse(input)
}

fn line(input: &str) -> IResult<&str, Option<Statement>> {
    all_consuming(map((space0, opt(statement), space0), |(_, s, _)| s)).parse(input)
}

fn colour(n: &[f32]) -> [f32; 3] {
    [n[0] / 255.0, n[1] / 255.0, n[2] / 255.0]
}

/// Parse a transfer function from text (see the module docs).
pub fn parse(text: &str) -> Result<TransferFunction, RenderError> {
    let mut tf = TransferFunction {
        points: vec![],
        ranges: vec![],
        domain: None,
        reference_step: 1.0,
    };
    for (i, raw) in text.lines().enumerate() {
        let err = |msg: String| RenderError::TfSyntax { line: i + 1, msg };
        let content = raw.split('#').next().unwrap_or("").trim_end();
        let (_, stmt) = line(content).map_err(|_| {
            err(format!(
                "cannot read '{}' (expected domain, step, point or range followed by numbers)",
                content.trim()
            ))
        })?;
        let unit = |v: f32, what: &str| {
            if (0.0..=1.0).contains(&v) {
                Ok(v)
            } else {
                Err(err(format!("{what} {v} is outside [0, 1]")))
            }
        };
        let byte = |n: &[f32]| {
            if n.iter().all(|c| (0.0..=255.0).contains(c)) {
                Ok(colour(n))
            } else {
                Err(err("colour components must be 0-255".into()))
            }
        };
        match stmt {
            None => {}
            Some(Statement::Domain(lo, hi)) => {
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err(err("domain needs two finite numbers, low < high".into()));
                }
                tf.domain = Some((lo, hi));
            }
            Some(Statement::Step(s)) => {
                if !(s > 0.0 && s.is_finite()) {
                    return Err(err(format!("step {s} must be positive")));
                }
                tf.reference_step = s;
            }
            Some(Statement::Point(n)) => {
                if n.len() != 5 {
                    return Err(err(format!(
                        "point takes 5 numbers (value R G B opacity), not {}",
                        n.len()
                    )));
                }
                if !n[0].is_finite() {
                    return Err(err("point value must be finite".into()));
                }
                tf.points.push(TfPoint {
                    value: n[0],
                    rgb: byte(&n[1..4])?,
                    alpha: unit(n[4], "opacity")?,
                });
            }
            Some(Statement::Range(n)) => {
                if n.len() != 6 {
                    return Err(err(format!(
                        "range takes 6 numbers (lo hi R G B opacity), not {}",
                        n.len()
                    )));
                }
                if !(n[0].is_finite() && n[1].is_finite() && n[0] < n[1]) {
                    return Err(err("range needs finite lo < hi".into()));
                }
                tf.ranges.push(TfRange {
                    lo: n[0],
                    hi: n[1],
                    rgb: byte(&n[2..5])?,
                    alpha: unit(n[5], "opacity")?,
                });
            }
        }
    }
    if tf.points.is_empty() && tf.ranges.is_empty() {
        return Err(RenderError::TfSyntax {
            line: text.lines().count().max(1),
            msg: "no point or range: everything would be transparent".into(),
        });
    }
    tf.points.sort_by(|a, b| a.value.total_cmp(&b.value));
    Ok(tf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_thesis_function_and_comments() {
        let text = "# shapes\ndomain 0 255\nstep 1\n\nrange 85 95 255 0 0 0.02\nrange 95 100 0 0 255 0.3   # blue\n  range 100 115 0 255 0 0.6\n";
        let tf = parse(text).unwrap();
        assert_eq!(
            tf,
            TransferFunction::preset("shapes", (0.0, 255.0)).unwrap()
        );
    }

    #[test]
    fn points_sort_and_errors_name_the_line() {
        let tf = parse("point 10 255 255 255 1\npoint 0 0 0 0 0").unwrap();
        assert_eq!(tf.points[0].value, 0.0);
        for (text, line) in [
            ("point 1 2 3", 1),
            ("step 1\nrange 5 4 0 0 0 1", 2),
            ("point 0 0 0 0 1.5", 1),
            ("point 0 300 0 0 1", 1),
            ("colour 1 2 3", 1),
            ("step 0\npoint 0 0 0 0 0", 1),
            ("domain 5 5", 1),
            ("# nothing\n", 1),
        ] {
            match parse(text) {
                Err(RenderError::TfSyntax { line: l, .. }) => assert_eq!(l, line, "{text}"),
                other => panic!("{text}: {other:?}"),
            }
        }
    }
}
