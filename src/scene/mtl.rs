//! MTL files and the MTL → material mapping of `shared/scene-format.md`:
//!
//! | MTL | material |
//! |---|---|
//! | `illum 5` | mirror, specular = Ks |
//! | `illum 7` | glass, ior = Ni |
//! | Ks > 0 (any other illum) | glossy, albedo = Kd, specular = Ks, roughness = sqrt(2 / (Ns + 2)) |
//! | otherwise | diffuse, albedo = Kd |
//! | Ke > 0 (any of the above) | also an emitter of radiance Ke |
//!
//! Our own small reader (not tobj's): tobj panics on a colour with fewer than three numbers,
//! keeps `#` comments inside values and reports no line numbers. Like
//! `shared/tools/mitsuba_ref.py` it reads only `newmtl`, `Kd`, `Ks`, `Ke`, `Ns`, `Ni` and
//! `illum` (everything after `#` is a comment; other statements are ignored) and uses the
//! same defaults for absent values: Kd = Ks = Ke = 0, Ns = 0, Ni = 1.5, illum = 2.
//! "Ks > 0" and "Ke > 0" mean: in at least one channel.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use super::error::SceneError;
use crate::material::{Bsdf, Material};

/// One `newmtl` block, as written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MtlEntry {
    pub kd: Option<Vec3>,
    pub ks: Option<Vec3>,
    pub ke: Option<Vec3>,
    pub ns: Option<f32>,
    pub ni: Option<f32>,
    pub illum: Option<i64>,
    /// Line of the `newmtl` statement.
    pub line: usize,
}

/// Reads the MTL file `path`: material name → entry.
pub fn read(path: &Path) -> Result<HashMap<String, MtlEntry>, SceneError> {
    parse(path, &super::error::read_text(path)?)
}

/// Parses MTL text (`path` is for messages). A name defined twice in one file is an error.
pub fn parse(path: &Path, text: &str) -> Result<HashMap<String, MtlEntry>, SceneError> {
    let mut out: HashMap<String, MtlEntry> = HashMap::new();
    let mut cur: Option<String> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let err = |p: String| SceneError::syntax(path, Some(line), p);
        let toks: Vec<&str> = raw.split('#').next().unwrap_or("").split_whitespace().collect();
        let Some((&key, args)) = toks.split_first() else { continue };
        if key == "newmtl" {
            let name = args.join(" ");
            if name.is_empty() {
                return Err(err("newmtl without a name".into()));
            }
            if out.contains_key(&name) {
                return Err(err(format!("material {name:?} is defined twice in this file")));
            }
            out.insert(name.clone(), MtlEntry { line, ..MtlEntry::default() });
            cur = Some(name);
            continue;
        }
        if !matches!(key, "Kd" | "Ks" | "Ke" | "Ns" | "Ni" | "illum") {
            continue;
        }
        let Some(entry) = cur.as_ref().and_then(|n| out.get_mut(n)) else {
            // Like mitsuba_ref.py: statements before the first newmtl belong to nothing.
            continue;
        };
        match key {
            "Kd" | "Ks" | "Ke" => {
                let v = colour(args).ok_or_else(|| {
                    err(format!("{key} {}: expected three finite numbers ≥ 0", args.join(" ")))
                })?;
                match key {
                    "Kd" => entry.kd = Some(v),
                    "Ks" => entry.ks = Some(v),
                    _ => entry.ke = Some(v),
                }
            }
            "Ns" | "Ni" => {
                let v = args.first().and_then(|s| s.parse::<f32>().ok()).filter(|v| v.is_finite());
                let v =
                    v.ok_or_else(|| err(format!("{key} {}: expected a finite number", args.join(" "))))?;
                if key == "Ns" {
                    entry.ns = Some(v);
                } else {
                    entry.ni = Some(v);
                }
            }
            _ => {
                let v = args.first().and_then(|s| s.parse::<i64>().ok());
                entry.illum =
                    Some(v.ok_or_else(|| err(format!("illum {}: expected an integer", args.join(" "))))?);
            }
        }
    }
    Ok(out)
}

fn colour(args: &[&str]) -> Option<Vec3> {
    if args.len() < 3 {
        return None;
    }
    let mut v = [0.0f32; 3];
    for (o, s) in v.iter_mut().zip(args) {
        *o = s.parse().ok()?;
    }
    v.iter().all(|x| x.is_finite() && *x >= 0.0).then(|| Vec3::from_array(v))
}

/// The material of MTL entry `name` by the mapping table (`path` is the MTL file, for
/// messages).
pub fn to_material(path: &Path, name: &str, m: &MtlEntry) -> Result<Material, SceneError> {
    let kd = m.kd.unwrap_or(Vec3::ZERO);
    let ks = m.ks.unwrap_or(Vec3::ZERO);
    let ke = m.ke.unwrap_or(Vec3::ZERO);
    let bsdf = match m.illum.unwrap_or(2) {
        5 => Bsdf::Mirror { specular: ks },
        7 => {
            let ior = m.ni.unwrap_or(1.5);
            if ior <= 0.0 {
                return Err(SceneError::syntax(
                    path,
                    Some(m.line),
                    format!("material {name:?}: illum 7 (glass) needs Ni > 0, got {ior}"),
                ));
            }
            Bsdf::Glass { ior }
        }
        _ if ks.max_element() > 0.0 => {
            let ns = m.ns.unwrap_or(0.0);
            if ns < 0.0 {
                return Err(SceneError::syntax(
                    path,
                    Some(m.line),
                    format!("material {name:?}: glossy (Ks > 0) needs Ns ≥ 0, got {ns}"),
                ));
            }
            Bsdf::Glossy { albedo: kd, specular: ks, roughness: (2.0 / (ns + 2.0)).sqrt() }
        }
        _ => Bsdf::Diffuse { albedo: kd },
    };
    if let Some((field, v)) = bsdf.creates_energy() {
        let mtl = if field == "albedo" { "Kd" } else { "Ks" };
        return Err(SceneError::syntax(
            path,
            Some(m.line),
            format!(
                "material {name:?}: {mtl} {} {} {}: a reflectance must not exceed 1 (the material would create \
                 energy; Mitsuba refuses it too)",
                v.x, v.y, v.z
            ),
        ));
    }
    let emission = if ke.max_element() > 0.0 { ke } else { Vec3::ZERO };
    Ok(Material { name: name.to_string(), bsdf, emission, two_sided: false, textures: None })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(text: &str) -> Material {
        let p = Path::new("t.mtl");
        let m = parse(p, text).unwrap();
        let (name, e) = m.iter().next().unwrap();
        to_material(p, name, e).unwrap()
    }

    #[test]
    fn mapping_table() {
        let mirror = one("newmtl a\nKd 0.1 0.1 0.1\nKs 0.95 0.9 0.8\nNs 1000\nillum 5\n");
        assert_eq!(mirror.bsdf, Bsdf::Mirror { specular: Vec3::new(0.95, 0.9, 0.8) });
        let glass = one("newmtl a\nKs 0.3 0.3 0.3\nNi 2.5\nillum 7\n");
        assert_eq!(glass.bsdf, Bsdf::Glass { ior: 2.5 });
        assert_eq!(one("newmtl a\nillum 7\n").bsdf, Bsdf::Glass { ior: 1.5 });
        let glossy = one("newmtl a\nKd 0.5 0.4 0.3\nKs 0 0.2 0\nNs 32\nillum 2\n");
        let Bsdf::Glossy { albedo, specular, roughness } = glossy.bsdf else { panic!() };
        assert_eq!((albedo, specular), (Vec3::new(0.5, 0.4, 0.3), Vec3::new(0.0, 0.2, 0.0)));
        assert!((roughness - (2.0f32 / 34.0).sqrt()).abs() < 1e-7);
        let diffuse = one("newmtl a\nKd 0.5 0.4 0.3 # comment\nKs 0 0 0\nKe 0 0 0\n");
        assert_eq!(diffuse.bsdf, Bsdf::Diffuse { albedo: Vec3::new(0.5, 0.4, 0.3) });
        assert!(!diffuse.is_emitter());
        let light = one("newmtl light\nKd 0.78 0.78 0.78\nKe 17 12 4\n");
        assert_eq!(light.emission, Vec3::new(17.0, 12.0, 4.0));
        // Ke applies to any kind.
        assert_eq!(one("newmtl a\nillum 5\nKe 1 0 0\n").emission, Vec3::X);
        // No Ks, no Ns: roughness of Ns = 0 would be 1, but no Ks means diffuse; Kd default 0.
        assert_eq!(one("newmtl a\n").bsdf, Bsdf::Diffuse { albedo: Vec3::ZERO });
    }

    #[test]
    fn bad_lines_name_the_line() {
        let p = Path::new("dir/t.mtl");
        for (text, want) in [
            ("newmtl a\nKd 0.5 0.5\n", "line 2: Kd"),
            ("newmtl a\n\nKs 1 nan 1\n", "line 3: Ks"),
            ("newmtl a\nKe -1 0 0\n", "line 2: Ke"),
            ("newmtl a\nNs x\n", "line 2: Ns"),
            ("newmtl a\nillum 2.0\n", "line 2: illum"),
            ("newmtl a\nnewmtl a\n", "line 2: material \"a\" is defined twice"),
            ("newmtl\n", "line 1: newmtl without a name"),
        ] {
            let e = parse(p, text).unwrap_err().to_string();
            assert!(e.contains("dir/t.mtl") && e.contains(want), "{e}");
        }
        let m = parse(p, "newmtl g\nKs 1 1 1\nNs -5\n").unwrap();
        let e = to_material(p, "g", &m["g"]).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("Ns"), "{e}");
    }
}
