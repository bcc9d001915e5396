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
//!
//! A 2D transfer function, over value and gradient magnitude (per unit of
//! world length), adds these statements; any of them makes the file 2D,
//! and its points and ranges then hold at every gradient magnitude:
//!
//! ```text
//! gradient-domain 0 120          # gradient magnitudes the table covers
//! rect 90 110  20 120  255 200 150  0.6   # [v0, v1) x [g0, g1): colour, opacity
//! blob 100 60  8 15    255 255 255  0.9   # centre v g, std devs, colour, peak opacity
//! ```
//!
//! At each (value, gradient) the part with the largest opacity wins (see
//! [`super::tf2d`]).

use super::{Tf, TfBlob, TfPoint, TfRange, TfRect, TransferFunction, TransferFunction2d};
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
    GradientDomain(f32, f32),
    Step(f32),
    Point(Vec<f32>),
    Range(Vec<f32>),
    Rect(Vec<f32>),
    Blob(Vec<f32>),
}

fn numbers(input: &str) -> IResult<&str, Vec<f32>> {
    separated_list1(space1, float).parse(input)
}

fn statement(input: &str) -> IResult<&str, Statement> {
    let keyword_then = |kw: &'static str| preceded((tag(kw), space1), numbers);
    let pair = |n: Vec<f32>| {
        (
            n.first().copied().unwrap_or(f32::NAN),
            if n.len() == 2 { n[1] } else { f32::NAN },
        )
    };
    alt((
        map(keyword_then("domain"), move |n| {
            let (lo, hi) = pair(n);
            Statement::Domain(lo, hi)
        }),
        map(keyword_then("gradient-domain"), move |n| {
            let (lo, hi) = pair(n);
            Statement::GradientDomain(lo, hi)
        }),
        map(keyword_then("step"), |n| Statement::Step(n[0])),
        map(keyword_then("point"), Statement::Point),
        map(keyword_then("range"), Statement::Range),
        map(keyword_then("rect"), Statement::Rect),
        map(keyword_then("blob"), Statement::Blob),
    ))
    .parse(input)
}

fn line(input: &str) -> IResult<&str, Option<Statement>> {
    all_consuming(map((space0, opt(statement), space0), |(_, s, _)| s)).parse(input)
}

fn colour(n: &[f32]) -> [f32; 3] {
    [n[0] / 255.0, n[1] / 255.0, n[2] / 255.0]
}

/// Parse a 1D transfer function from text (see the module docs); a 2D
/// file is an error naming its first 2D statement.
pub fn parse(text: &str) -> Result<TransferFunction, RenderError> {
    match parse_any(text)? {
        Tf::OneD(tf) => Ok(tf),
        Tf::TwoD(_) => {
            let line = text
                .lines()
                .position(|l| {
                    let l = l.trim_start();
                    ["rect", "blob", "gradient-domain"]
                        .iter()
                        .any(|k| l.starts_with(k))
                })
                .map_or(1, |i| i + 1);
            Err(RenderError::TfSyntax {
                line,
                msg: "a 2D statement where a 1D transfer function is expected".into(),
            })
        }
    }
}

/// Parse a transfer function of either kind from text (see the module
/// docs).
pub fn parse_any(text: &str) -> Result<Tf, RenderError> {
    let mut tf = TransferFunction {
        points: vec![],
        ranges: vec![],
        domain: None,
        reference_step: 1.0,
    };
    let (mut rects, mut blobs, mut gradient_domain) = (Vec::new(), Vec::new(), None);
    let mut two_d = false;
    for (i, raw) in text.lines().enumerate() {
        let err = |msg: String| RenderError::TfSyntax { line: i + 1, msg };
        let content = raw.split('#').next().unwrap_or("").trim_end();
        let (_, stmt) = line(content).map_err(|_| {
            err(format!(
                "cannot read '{}' (expected domain, step, point, range, gradient-domain, rect or blob followed by numbers)",
                volcore::text::excerpt(content.trim())
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
        let count = |n: &[f32], want: usize, what: &str| {
            if n.len() == want {
                Ok(())
            } else {
                Err(err(format!("{what}, not {}", n.len())))
            }
        };
        match stmt {
            None => {}
            Some(Statement::Domain(lo, hi)) => {
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err(err("domain needs two finite numbers, low < high".into()));
                }
                // The table divides high - low into bins: in f32 it must
                // be finite too.
                if !(hi - lo).is_finite() {
                    return Err(err(format!(
                        "domain {lo:e} {hi:e} is too wide: high - low must be at most {:e}",
                        f32::MAX
                    )));
                }
                tf.domain = Some((lo, hi));
            }
            Some(Statement::GradientDomain(lo, hi)) => {
                if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi) {
                    return Err(err(
                        "gradient-domain needs two finite numbers, 0 <= low < high".into(),
                    ));
                }
                gradient_domain = Some((lo, hi));
                two_d = true;
            }
            Some(Statement::Step(s)) => {
                if !(s > 0.0 && s.is_finite()) {
                    return Err(err(format!("step {s} must be positive")));
                }
                tf.reference_step = s;
            }
            Some(Statement::Point(n)) => {
                count(&n, 5, "point takes 5 numbers (value R G B opacity)")?;
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
                count(&n, 6, "range takes 6 numbers (lo hi R G B opacity)")?;
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
            Some(Statement::Rect(n)) => {
                count(
                    &n,
                    8,
                    "rect takes 8 numbers (value-lo value-hi gradient-lo gradient-hi R G B opacity)",
                )?;
                if !(n[..4].iter().all(|v| v.is_finite()) && n[0] < n[1] && n[2] < n[3]) {
                    return Err(err(
                        "rect needs finite bounds, value-lo < value-hi and gradient-lo < gradient-hi"
                            .into(),
                    ));
                }
                rects.push(TfRect {
                    lo: n[0],
                    hi: n[1],
                    glo: n[2],
                    ghi: n[3],
                    rgb: byte(&n[4..7])?,
                    alpha: unit(n[7], "opacity")?,
                });
                two_d = true;
            }
            Some(Statement::Blob(n)) => {
                count(
                    &n,
                    8,
                    "blob takes 8 numbers (value gradient value-sd gradient-sd R G B opacity)",
                )?;
                if !(n[..4].iter().all(|v| v.is_finite()) && n[2] > 0.0 && n[3] > 0.0) {
                    return Err(err(
                        "blob needs a finite centre and positive standard deviations".into(),
                    ));
                }
                blobs.push(TfBlob {
                    value: n[0],
                    gradient: n[1],
                    value_sd: n[2],
                    gradient_sd: n[3],
                    rgb: byte(&n[4..7])?,
                    alpha: unit(n[7], "opacity")?,
                });
                two_d = true;
            }
        }
    }
    if tf.points.is_empty() && tf.ranges.is_empty() && rects.is_empty() && blobs.is_empty() {
        return Err(RenderError::TfSyntax {
            line: text.lines().count().max(1),
            msg: "no point, range, rect or blob: everything would be transparent".into(),
        });
    }
    tf.points.sort_by(|a, b| a.value.total_cmp(&b.value));
    Ok(if two_d {
        Tf::TwoD(TransferFunction2d {
            base: tf,
            rects,
            blobs,
            gradient_domain,
        })
    } else {
        Tf::OneD(tf)
    })
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
            ("point 0 0 0 0 1\nrect 1 2 3 4 0 0 0", 2),
            ("rect 2 1 0 5 0 0 0 1", 1),
            ("rect 1 2 5 5 0 0 0 1", 1),
            ("blob 1 2 0 3 0 0 0 1", 1),
            ("blob 1 2 1 3 0 0 0 2", 1),
            ("gradient-domain -1 5\npoint 0 0 0 0 1", 1),
            ("gradient-domain 5\npoint 0 0 0 0 1", 1),
            ("domain 0 1 2\npoint 0 0 0 0 1", 1),
            ("point 0 0 0 0 1\n\nblob 1 2 1 3 0 0 0 1", 3),
        ] {
            match parse(text) {
                Err(RenderError::TfSyntax { line: l, .. }) => assert_eq!(l, line, "{text}"),
                other => panic!("{text}: {other:?}"),
            }
        }
    }

    #[test]
    fn control_bytes_and_long_lines_are_escaped_and_cut_in_messages() {
        let long = "x".repeat(5000);
        for text in ["point \x1b[2J\x07 0 0 0 1", "\0\u{202e}evil", long.as_str()] {
            let msg = parse_any(text).unwrap_err().to_string();
            assert!(!msg.chars().any(volcore::text::is_unsafe_char), "{msg:?}");
            assert!(msg.len() < 400, "{} characters", msg.len());
        }
        let msg = parse_any("point \x1b[2J 0").unwrap_err().to_string();
        assert!(msg.contains("\\x1b[2J"), "{msg}");
    }

    #[test]
    fn two_d_statements_make_a_2d_function() {
        let text = "domain 0 255\ngradient-domain 0 100\npoint 0 0 0 0 0\npoint 255 255 255 255 0.1\nrect 90 110 20 100 255 0 0 0.6\nblob 200 50 10 10 0 0 255 0.9";
        let Tf::TwoD(tf) = parse_any(text).unwrap() else {
            panic!("not 2D")
        };
        assert_eq!(tf.gradient_domain, Some((0.0, 100.0)));
        assert_eq!(tf.base.domain, Some((0.0, 255.0)));
        assert_eq!(
            (tf.rects.len(), tf.blobs.len(), tf.base.points.len()),
            (1, 1, 2)
        );
        assert_eq!(tf.eval(100.0, 50.0), ([1.0, 0.0, 0.0], 0.6));
        assert_eq!(tf.eval(200.0, 50.0), ([0.0, 0.0, 1.0], 0.9));
        // A 1D file stays 1D.
        assert!(matches!(parse_any("point 0 0 0 0 1"), Ok(Tf::OneD(_))));
    }
}
