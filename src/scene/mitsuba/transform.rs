//! `<transform>`: its operations in document order, each applied after the ones before it
//! (Mitsuba's `transform = op · transform`): `translate`, `rotate` (axis and angle in
//! degrees, right-handed), `scale`, `matrix` (4×4 or 3×3, row by row) and `lookat`.

use glam::{Mat3, Mat4, Vec3};

use super::xml::Element;
use crate::scene::SceneError;

/// The matrix of a `<transform>` element.
pub fn parse(t: &Element) -> Result<Mat4, SceneError> {
    let mut m = Mat4::IDENTITY;
    for op in &t.children {
        let step = match op.tag.as_str() {
            "translate" => Mat4::from_translation(xyz(op, 0.0)?),
            "scale" => {
                let s = match op.attr("value") {
                    Some(v) => match numbers(op, v)?.as_slice() {
                        [s] => Vec3::splat(*s),
                        [x, y, z] => Vec3::new(*x, *y, *z),
                        _ => return Err(op.error("value: expected one number or three")),
                    },
                    None => xyz(op, 1.0)?,
                };
                Mat4::from_scale(s)
            }
            "rotate" => {
                let axis = xyz(op, 0.0)?;
                let angle = number(op, "angle")?.unwrap_or(0.0);
                if axis.length_squared() == 0.0 {
                    return Err(op.error("the rotation axis is zero"));
                }
                Mat4::from_axis_angle(axis.normalize(), angle.to_radians())
            }
            "matrix" => {
                let v = numbers(op, op.attr("value").ok_or_else(|| op.error("needs a value"))?)?;
                match v.len() {
                    16 => Mat4::from_cols_array(&v.try_into().expect("16 numbers")).transpose(),
                    9 => {
                        Mat4::from_mat3(Mat3::from_cols_array(&v.try_into().expect("9 numbers")).transpose())
                    }
                    n => return Err(op.error(format!("value: {n} numbers, expected 16 (4×4) or 9 (3×3)"))),
                }
            }
            "lookat" => {
                let point = |key: &str| -> Result<Vec3, SceneError> {
                    let v = op.attr(key).ok_or_else(|| op.error(format!("needs {key}")))?;
                    match numbers(op, v)?.as_slice() {
                        [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
                        _ => Err(op.error(format!("{key}: expected three numbers"))),
                    }
                };
                let (origin, target) = (point("origin")?, point("target")?);
                let up = if op.attr("up").is_some() { point("up")? } else { Vec3::Y };
                look_at(origin, target, up).ok_or_else(|| {
                    op.error("origin and target coincide, or up is parallel to the viewing direction")
                })?
            }
            other => {
                return Err(op.error(format!(
                    "<{other}> is not a transform operation (translate, rotate, scale, matrix, lookat)"
                )));
            }
        };
        m = step * m;
    }
    if !m.is_finite() {
        return Err(t.error("the transform is not finite"));
    }
    Ok(m)
}

/// Mitsuba's look-at matrix: the columns are left = up × dir, up' = dir × left, dir, origin.
pub fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Option<Mat4> {
    let dir = (target - origin).try_normalize()?;
    let left = up.cross(dir).try_normalize()?;
    let new_up = dir.cross(left);
    Some(Mat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), origin.extend(1.0)))
}

/// The `x`, `y`, `z` attributes (each `default` when absent), or a `value` of three numbers.
fn xyz(op: &Element, default: f32) -> Result<Vec3, SceneError> {
    if let Some(v) = op.attr("value") {
        return match numbers(op, v)?.as_slice() {
            [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
            _ => Err(op.error("value: expected three numbers")),
        };
    }
    Ok(Vec3::new(
        number(op, "x")?.unwrap_or(default),
        number(op, "y")?.unwrap_or(default),
        number(op, "z")?.unwrap_or(default),
    ))
}

fn number(op: &Element, key: &str) -> Result<Option<f32>, SceneError> {
    op.attr(key)
        .map(|v| parse_number(v).ok_or_else(|| op.error(format!("{key}=\"{v}\": not a finite number"))))
        .transpose()
}

/// Numbers separated by commas and/or white space.
pub fn numbers(e: &Element, v: &str) -> Result<Vec<f32>, SceneError> {
    v.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| parse_number(s).ok_or_else(|| e.error(format!("\"{s}\": not a finite number"))))
        .collect()
}

/// A finite number.
pub fn parse_number(s: &str) -> Option<f32> {
    s.trim().parse::<f32>().ok().filter(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_is_mitsubas() {
        let m = look_at(Vec3::new(0.0, 1.0, 6.8), Vec3::new(0.0, 1.0, 5.8), Vec3::Y).unwrap();
        // The Cornell box's camera matrix: -1 0 0 0 / 0 1 0 1 / 0 0 -1 6.8.
        let want = Mat4::from_cols_array(&[
            -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 6.8, 1.0,
        ]);
        assert!(m.abs_diff_eq(want, 1e-6), "{m}");
    }
}
