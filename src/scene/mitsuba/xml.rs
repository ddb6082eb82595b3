//! The XML layer of Mitsuba 3 scene files: the document read into owned elements with what
//! Mitsuba's parser does before it instantiates anything:
//! - `<default name value>` gives a parameter's value unless the command line set it
//!   (`-D name=value`), and every `$name` in an attribute is replaced by its value;
//! - `<include filename>` splices the `<scene>` of another file (relative to the including
//!   one) in its place;
//! - files older than version 2.0 (Mitsuba 0.6) are upgraded as Mitsuba 3 upgrades them:
//!   parameter names from camelCase to snake_case, `lookAt` to `lookat`;
//! - every element remembers its file and line, for errors that name both.
//!
//! References (`<ref id>`) are resolved by the scene builder ([`super::Doc::resolve`]), so
//! that a definition used many times is read once and a file cannot make the tree grow
//! exponentially.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::scene::SceneError;
use crate::scene::error::read_text;

/// Deepest nesting of `<include>` (a file that includes itself fails here).
const MAX_INCLUDE_DEPTH: usize = 16;
/// Most elements of a scene, all files together (a bound on what a file can make pir allocate
/// beyond its own size).
const MAX_ELEMENTS: usize = 4_000_000;

/// One XML element of the scene, its attributes after substitution.
#[derive(Debug)]
pub struct Element {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub file: Arc<PathBuf>,
    pub line: usize,
}

impl Element {
    /// The value of attribute `key`.
    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// The `type` attribute, or "" when it has none.
    pub fn type_name(&self) -> &str {
        self.attr("type").unwrap_or("")
    }

    /// The element as errors name it: `<bsdf type="plastic" id="floor">`.
    pub fn describe(&self) -> String {
        let mut s = format!("<{}", self.tag);
        for key in ["type", "id", "name"] {
            if let Some(v) = self.attr(key) {
                s.push_str(&format!(" {key}=\"{v}\""));
            }
        }
        s.push('>');
        s
    }

    /// An error about this element: `FILE: line N: <tag …>: problem`.
    pub fn error(&self, problem: impl Into<String>) -> SceneError {
        SceneError::Value {
            path: self.file.as_ref().clone(),
            line: Some(self.line),
            key: self.describe(),
            problem: problem.into(),
        }
    }
}

/// A scene file read with its includes, defaults substituted.
pub struct Document {
    /// The children of `<scene>`, includes spliced in, `<default>`s removed.
    pub elements: Vec<Element>,
}

/// Reads `path` as a Mitsuba scene, `defines` the command line's `-D name=value`.
pub fn read(path: &Path, defines: &[(String, String)]) -> Result<Document, SceneError> {
    let mut params: HashMap<String, String> = defines.iter().cloned().collect();
    let mut reader = Reader { count: 0, defined: defines.iter().map(|(k, _)| k.clone()).collect() };
    let elements = reader.file(path, &mut params, 0)?;
    Ok(Document { elements })
}

struct Reader {
    /// Elements read so far.
    count: usize,
    /// Parameters the command line set (a `<default>` does not override them).
    defined: Vec<String>,
}

impl Reader {
    fn file(
        &mut self,
        path: &Path,
        params: &mut HashMap<String, String>,
        depth: usize,
    ) -> Result<Vec<Element>, SceneError> {
        let text = read_text(path)?;
        let doc = roxmltree::Document::parse_with_options(
            &text,
            roxmltree::ParsingOptions {
                allow_dtd: false,
                nodes_limit: MAX_ELEMENTS as u32,
                ..Default::default()
            },
        )
        .map_err(|e| SceneError::syntax(path, Some(e.pos().row as usize), format!("malformed XML: {e}")))?;
        let root = doc.root_element();
        let file = Arc::new(path.to_path_buf());
        let line_of = |n: roxmltree::Node| doc.text_pos_at(n.range().start).row as usize;
        if root.tag_name().name() != "scene" {
            return Err(SceneError::syntax(
                path,
                Some(line_of(root)),
                format!("the root element is <{}>, not <scene>", root.tag_name().name()),
            ));
        }
        let version = root.attribute("version").ok_or_else(|| {
            SceneError::syntax(
                path,
                Some(line_of(root)),
                "<scene> has no version attribute (e.g. version=\"3.0.0\")",
            )
        })?;
        let upgrade = old_version(version).ok_or_else(|| {
            SceneError::syntax(
                path,
                Some(line_of(root)),
                format!("<scene version=\"{version}\">: not a version number"),
            )
        })?;
        let mut out = Vec::new();
        for node in root.children().filter(|n| n.is_element()) {
            let line = line_of(node);
            match node.tag_name().name() {
                "default" => {
                    let (Some(name), Some(value)) = (node.attribute("name"), node.attribute("value")) else {
                        return Err(SceneError::syntax(
                            path,
                            Some(line),
                            "<default> needs a name and a value",
                        ));
                    };
                    if !self.defined.iter().any(|d| d == name) {
                        params.insert(name.to_string(), value.to_string());
                    }
                }
                "include" => {
                    let Some(name) = node.attribute("filename") else {
                        return Err(SceneError::syntax(path, Some(line), "<include> needs a filename"));
                    };
                    let name =
                        substitute(name, params).map_err(|p| SceneError::syntax(path, Some(line), p))?;
                    if depth + 1 > MAX_INCLUDE_DEPTH {
                        return Err(SceneError::syntax(
                            path,
                            Some(line),
                            format!(
                                "<include filename=\"{name}\">: includes nested deeper than {MAX_INCLUDE_DEPTH} (a cycle?)"
                            ),
                        ));
                    }
                    let included = path.parent().unwrap_or(Path::new("")).join(&name);
                    out.extend(self.file(&included, params, depth + 1)?);
                }
                _ => out.push(self.element(node, &doc, &file, params, upgrade)?),
            }
        }
        Ok(out)
    }

    fn element(
        &mut self,
        node: roxmltree::Node,
        doc: &roxmltree::Document,
        file: &Arc<PathBuf>,
        params: &HashMap<String, String>,
        upgrade: bool,
    ) -> Result<Element, SceneError> {
        self.count += 1;
        let line = doc.text_pos_at(node.range().start).row as usize;
        if self.count > MAX_ELEMENTS {
            return Err(SceneError::syntax(file, Some(line), format!("more than {MAX_ELEMENTS} elements")));
        }
        let mut tag = node.tag_name().name().to_string();
        if upgrade && tag == "lookAt" {
            tag = "lookat".into();
        }
        let mut attrs = Vec::new();
        for a in node.attributes() {
            let mut value = substitute(a.value(), params)
                .map_err(|p| SceneError::syntax(file, Some(line), format!("<{tag}>: {p}")))?;
            if upgrade && a.name() == "name" {
                value = snake_case(&value);
            }
            attrs.push((a.name().to_string(), value));
        }
        let mut children = Vec::new();
        for c in node.children().filter(|n| n.is_element()) {
            children.push(self.element(c, doc, file, params, upgrade)?);
        }
        Ok(Element { tag, attrs, children, file: file.clone(), line })
    }
}

/// Whether a scene of this version is a Mitsuba 0.6 file (older than 2.0), or `None` for a
/// version that is not one.
fn old_version(v: &str) -> Option<bool> {
    let major: u32 = v.split('.').next()?.trim().parse().ok()?;
    if !v.split('.').all(|p| p.trim().parse::<u32>().is_ok()) {
        return None;
    }
    Some(major < 2)
}

/// `s` with every `$name` replaced by its parameter; an unknown name is an error.
fn substitute(s: &str, params: &HashMap<String, String>) -> Result<String, String> {
    if !s.contains('$') {
        return Ok(s.to_string());
    }
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find('$') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let len = after.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(after.len());
        let name = &after[..len];
        if name.is_empty() {
            return Err(format!("\"{s}\": a `$` without a parameter name"));
        }
        match params.get(name) {
            Some(v) => out.push_str(v),
            None => return Err(format!("\"{s}\": parameter ${name} has no <default> and no -D {name}=…")),
        }
        rest = &after[len..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Mitsuba 0.6's camelCase names in Mitsuba 3's snake_case (`intIOR` → `int_ior`,
/// `sampleCount` → `sample_count`).
fn snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    for (i, &c) in chars.iter().enumerate() {
        if c.is_ascii_uppercase() {
            let prev_lower = i > 0 && (chars[i - 1].is_ascii_lowercase() || chars[i - 1].is_ascii_digit());
            let next_lower = chars.get(i + 1).is_some_and(|n| n.is_ascii_lowercase());
            let prev_upper = i > 0 && chars[i - 1].is_ascii_uppercase();
            if i > 0 && (prev_lower || (prev_upper && next_lower)) {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_names_upgrade_as_mitsuba_does() {
        for (old, new) in [
            ("intIOR", "int_ior"),
            ("extIOR", "ext_ior"),
            ("sampleCount", "sample_count"),
            ("toWorld", "to_world"),
            ("maxDepth", "max_depth"),
            ("fovAxis", "fov_axis"),
            ("specularReflectance", "specular_reflectance"),
            ("alpha", "alpha"),
            ("uvscale", "uvscale"),
        ] {
            assert_eq!(snake_case(old), new);
        }
    }

    #[test]
    fn parameters_substitute_and_unknown_ones_are_errors() {
        let params: HashMap<String, String> = [("spp".to_string(), "64".to_string())].into();
        assert_eq!(substitute("$spp", &params).unwrap(), "64");
        assert_eq!(substitute("a $spp b", &params).unwrap(), "a 64 b");
        assert!(substitute("$res", &params).unwrap_err().contains("$res"));
        assert!(substitute("$", &params).is_err());
    }

    #[test]
    fn versions() {
        assert_eq!(old_version("3.0.0"), Some(false));
        assert_eq!(old_version("0.6.0"), Some(true));
        assert_eq!(old_version("x"), None);
        assert_eq!(old_version("3.a"), None);
    }
}
