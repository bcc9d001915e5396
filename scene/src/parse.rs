//! The parsers of option values that are more than a number or a name
//! (`WxH`, `x,y,z`, colours, `N[:R]`, shadow methods, suns): clap calls
//! them on the command line, and the resolution ([`crate::plan`]) on
//! values from a scene file.

use crate::choices::UpArg;
use glam::Vec3;

/// A positive finite number (`--adaptive`'s tolerance).
pub fn parse_positive(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a positive number")),
    }
}

/// A positive finite number in f64 (`--budget`'s seconds).
pub fn parse_positive_f64(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a positive number")),
    }
}

/// `WxH` within 1..=32768 per side.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', ','])
        .ok_or_else(|| format!("'{s}' is not WxH"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("'{s}' is not WxH"))
    };
    match (p(w)?, p(h)?) {
        (w, h) if (1..=32768).contains(&w) && (1..=32768).contains(&h) => Ok((w, h)),
        _ => Err(format!("'{s}': width and height must be 1..=32768")),
    }
}

/// `x,y,z` or `patient`.
pub fn parse_up(s: &str) -> Result<UpArg, String> {
    if s.trim().eq_ignore_ascii_case("patient") {
        return Ok(UpArg::Patient);
    }
    parse_vec3(s).map(UpArg::Vector)
}

/// Three finite numbers `x,y,z`.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not x,y,z"))?;
    match v[..] {
        [x, y, z] if [x, y, z].iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("'{s}' is not three finite numbers x,y,z")),
    }
}

/// A grey level `g` or linear `r,g,b`, finite and not negative.
pub fn parse_colour(s: &str) -> Result<Vec3, String> {
    let c = match s.trim().parse::<f32>() {
        Ok(g) => Vec3::splat(g),
        Err(_) => parse_vec3(s).map_err(|_| format!("'{s}' is not a grey level or r,g,b"))?,
    };
    if c.is_finite() && c.min_element() >= 0.0 {
        Ok(c)
    } else {
        Err(format!(
            "'{s}': colour components must be finite and not negative"
        ))
    }
}

/// `--ao` and `--ao-field`: checked here, resolved by [`ao_spec`].
pub(crate) fn parse_ao(s: &str) -> Result<String, String> {
    ao_spec(s).map(|_| s.to_string())
}

/// A direction count with an optional radius, `N` or `N:R` (N at least 1,
/// R finite and not negative).
pub fn ao_spec(s: &str) -> Result<(u32, Option<f32>), String> {
    let bad = || {
        format!(
            "`{}`: expected N or N:R, N a whole number of directions from 1, R a radius in world units",
            volcore::text::clip(&volcore::text::escape(s), 40)
        )
    };
    let (n, r) = match s.split_once(':') {
        Some((n, r)) => (n, Some(r)),
        None => (s, None),
    };
    let n: u32 = n.trim().parse().map_err(|_| bad())?;
    let r = match r {
        Some(r) => {
            let r: f32 = r.trim().parse().map_err(|_| bad())?;
            if !(r.is_finite() && r >= 0.0) {
                return Err(bad());
            }
            Some(r)
        }
        None => None,
    };
    if n == 0 {
        return Err(bad());
    }
    Ok((n, r))
}

/// `--shadows`: checked here, resolved by [`shadow_method`].
pub(crate) fn parse_shadows(s: &str) -> Result<String, String> {
    shadow_method(s).map(|_| s.to_string())
}

/// The shadow method named `ray`, `grid` or `grid:DIV` (DIV 1, 2 or 4;
/// `grid` alone is divisor 2).
pub fn shadow_method(s: &str) -> Result<volrender::ShadowMethod, String> {
    use volrender::ShadowMethod;
    match s {
        "ray" => Ok(ShadowMethod::Ray),
        "grid" => Ok(ShadowMethod::Grid { divisor: 2 }),
        _ => match s.strip_prefix("grid:").map(str::parse::<u32>) {
            Some(Ok(d @ (1 | 2 | 4))) => Ok(ShadowMethod::Grid { divisor: d }),
            _ => Err(format!(
                "`{}`: expected ray, grid, or grid:DIV with DIV 1, 2 or 4",
                volcore::text::clip(&volcore::text::escape(s), 40)
            )),
        },
    }
}

/// `--sun`: checked here, resolved by [`sun_spec`].
pub(crate) fn parse_sun_arg(s: &str) -> Result<String, String> {
    sun_spec(s).map(|_| s.to_string())
}

/// A sun `dx,dy,dz[:E]`: the direction it travels (not zero) and its
/// irradiance (grey, finite, not negative; default 3).
pub fn sun_spec(s: &str) -> Result<(Vec3, f32), String> {
    let (d, e) = match s.split_once(':') {
        Some((d, e)) => (d, Some(e)),
        None => (s, None),
    };
    let shown = || volcore::text::clip(&volcore::text::escape(s), 40);
    let dir = parse_vec3(d).map_err(|_| format!("`{}`: expected dx,dy,dz[:E]", shown()))?;
    if dir == Vec3::ZERO {
        return Err(format!("`{}`: the direction must not be zero", shown()));
    }
    let e = match e {
        Some(e) => e
            .trim()
            .parse::<f32>()
            .ok()
            .filter(|e| e.is_finite() && *e >= 0.0)
            .ok_or_else(|| format!("`{}`: the irradiance must be a finite number >= 0", shown()))?,
        None => 3.0,
    };
    Ok((dir, e))
}
