//! Reading and writing our JSON files with precise error locations.
//!
//! Every loader goes through [`read_json`]: the file size is checked against [`Limits`] before
//! reading, syntax errors report line and column, and type errors report the JSON path of the
//! field (`frames[12].contacts[3].link`) through `serde_path_to_error`. Semantic checks (finite
//! numbers, unit quaternions, consistent lengths) happen afterwards in each format's
//! `validate`, with the same path style, through [`FieldCheck`].

use std::io::Write;
use std::path::{Path, PathBuf};

use nalgebra::{Point3, UnitQuaternion, Vector3};
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::math::rotation::{self, RotationError};
use crate::{Error, Limits, Result};

pub use crate::math::rotation::QUAT_NORM_TOLERANCE;

/// Reads `path` and deserializes it, checking the size first and naming the failing field.
pub fn read_json<T: DeserializeOwned>(path: &Path, limits: &Limits) -> Result<T> {
    let bytes = read_limited(path, limits, limits.max_file_bytes, "--max-file-mb")?;
    parse_json(path, &bytes)
}

/// Reads a whole file of at most `limit` bytes, refusing special files (see
/// [`Limits::read_file`]).
pub fn read_limited(
    path: &Path,
    limits: &Limits,
    limit: u64,
    flag: &'static str,
) -> Result<Vec<u8>> {
    limits.read_file(path, limit, flag)
}

/// The formats of our files and what each is, for "this is a config, not a demonstration".
const KNOWN_FORMATS: [(&str, &str); 4] = [
    ("dexwarp.demo/1", "a demonstration"),
    ("dexwarp.config/1", "a warp config"),
    ("dexwarp.scene/1", "a scene"),
    ("dexwarp.report/1", "a report"),
];

/// [`read_json`] for a file whose `format` must be `expected`: when the typed parse fails and
/// the file is another of our formats, the error says which (a config given where a
/// demonstration is expected), rather than naming the first missing field.
pub fn read_json_format<T: DeserializeOwned>(
    path: &Path,
    limits: &Limits,
    expected: &str,
) -> Result<T> {
    let bytes = read_limited(path, limits, limits.max_file_bytes, "--max-file-mb")?;
    parse_json(path, &bytes).map_err(|err| wrong_format(path, &bytes, expected).unwrap_or(err))
}

/// The error for a file of another known format than `expected`, if it is one.
fn wrong_format(path: &Path, bytes: &[u8], expected: &str) -> Option<Error> {
    #[derive(serde::Deserialize)]
    struct FormatOnly {
        format: String,
    }
    let found = serde_json::from_slice::<FormatOnly>(bytes).ok()?.format;
    if found == expected {
        return None;
    }
    let what = |f: &str| KNOWN_FORMATS.iter().find(|(k, _)| *k == f).map(|(_, w)| *w);
    let (found_what, expected_what) = (what(&found)?, what(expected).unwrap_or("another file"));
    Some(Error::invalid(
        path,
        "format",
        format!(
            "is {found:?}: this file is {found_what}; expected {expected_what} ({expected:?}) here"
        ),
    ))
}

/// Deserializes JSON text, mapping errors to [`Error::Parse`] with a JSON path or a position.
pub fn parse_json<T: DeserializeOwned>(path: &Path, bytes: &[u8]) -> Result<T> {
    let de = &mut serde_json::Deserializer::from_slice(bytes);
    let value: T = serde_path_to_error::deserialize(de).map_err(|err| {
        let field = err.path().to_string();
        let inner = err.into_inner();
        parse_error(path, bytes, field, inner)
    })?;
    Ok(value)
}

fn parse_error(path: &Path, bytes: &[u8], field: String, err: serde_json::Error) -> Error {
    use serde_json::error::Category;
    let (line, column) = (err.line(), err.column());
    match err.classify() {
        Category::Syntax | Category::Eof | Category::Io => {
            let mut message = strip_position(&err.to_string());
            if mentions_non_finite(bytes) {
                message.push_str(
                    "; JSON has no NaN or Infinity: write finite numbers (a NaN in the source data must be fixed or the frame dropped)",
                );
            }
            Error::Parse {
                path: path.to_path_buf(),
                field: format!("line {line}, column {column}"),
                message,
            }
        }
        Category::Data => Error::Parse {
            path: path.to_path_buf(),
            field: if field == "." {
                "(top level)".into()
            } else {
                field
            },
            message: with_suggestion(strip_position(&err.to_string())),
        },
    }
}

/// serde's "unknown field `barrier`, expected one of `name`, `barriers`, ..." (or
/// "expected `x` or `y`", or "unknown variant ...") with the nearest known name appended when
/// one is close: "did you mean `barriers`?".
pub(crate) fn with_suggestion(message: String) -> String {
    let Some(rest) = message
        .strip_prefix("unknown field `")
        .or_else(|| message.strip_prefix("unknown variant `"))
    else {
        return message;
    };
    let Some((unknown, expected)) = rest.split_once('`') else {
        return message;
    };
    let known: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
    match nearest_name(unknown, &known) {
        Some(k) => format!("{message}; did you mean `{k}`?"),
        None => message,
    }
}

/// The name in `known` nearest to `word` by edit distance, if it is at most a third of the
/// longer name's length (at least 1) away: a typo, not another word.
pub fn nearest_name<'a>(word: &str, known: &[&'a str]) -> Option<&'a str> {
    known
        .iter()
        .map(|k| {
            (
                strsim::levenshtein(&word.to_lowercase(), &k.to_lowercase()),
                *k,
            )
        })
        .filter(|(d, k)| *d <= (word.chars().count().max(k.chars().count()) / 3).max(1))
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k)
}

pub(crate) fn strip_position(message: &str) -> String {
    match message.find(" at line ") {
        Some(i) => message[..i].to_string(),
        None => message.to_string(),
    }
}

fn mentions_non_finite(bytes: &[u8]) -> bool {
    let text = String::from_utf8_lossy(bytes);
    text.contains("NaN") || text.contains("Infinity")
}

/// Serializes `value` as pretty JSON to `path` atomically: a temporary file in the same
/// folder, then a rename, so an interrupted run never leaves a truncated file.
pub fn write_json_atomic<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let mut text = serde_json::to_vec_pretty(value).map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        field: "(output)".into(),
        message: e.to_string(),
    })?;
    text.push(b'\n');
    write_atomic(path, &text)
}

/// Writes bytes to `path` atomically (temporary file in the same folder, then rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(|e| Error::write(&dir, e))?;
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{file_name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::write(path, e));
    }
    Ok(())
}

/// Resolves a path written inside `file` relative to that file's folder.
pub fn resolve_relative(file: &Path, written: &Path) -> PathBuf {
    if written.is_absolute() {
        written.to_path_buf()
    } else {
        file.parent().unwrap_or(Path::new(".")).join(written)
    }
}

/// A number as a person reads it: plain when moderate, `1e-300` style when tiny or huge.
fn num(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Semantic checks on parsed values, each naming the file and the JSON path.
#[derive(Debug, Clone, Copy)]
pub struct FieldCheck<'a> {
    pub path: &'a Path,
}

impl<'a> FieldCheck<'a> {
    pub fn new(path: &'a Path) -> Self {
        FieldCheck { path }
    }

    /// A finite number.
    pub fn finite(&self, field: impl FnOnce() -> String, v: f64) -> Result<f64> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(Error::invalid(
                self.path,
                field(),
                format!("is {v}; expected a finite number"),
            ))
        }
    }

    /// A finite number strictly greater than zero.
    pub fn positive(&self, field: impl FnOnce() -> String, v: f64, unit: &str) -> Result<f64> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(Error::invalid(
                self.path,
                field(),
                format!("is {v}; expected a finite number > 0 ({unit})"),
            ))
        }
    }

    /// A finite number ≥ 0.
    pub fn non_negative(&self, field: impl FnOnce() -> String, v: f64, unit: &str) -> Result<f64> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(Error::invalid(
                self.path,
                field(),
                format!("is {v}; expected a finite number >= 0 ({unit})"),
            ))
        }
    }

    /// A point or vector with three finite coordinates.
    pub fn vec3(&self, field: impl FnOnce() -> String, v: [f64; 3]) -> Result<Vector3<f64>> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(Vector3::from(v))
        } else {
            Err(Error::invalid(
                self.path,
                field(),
                format!("is {v:?}; expected three finite numbers (metres)"),
            ))
        }
    }

    /// A world position: three finite coordinates within
    /// [`WORLD_HALF_EXTENT_M`](crate::limits::WORLD_HALF_EXTENT_M) of the origin.
    pub fn world_vec3(&self, field: impl Fn() -> String, v: [f64; 3]) -> Result<Vector3<f64>> {
        self.bounded_vec3(
            field,
            v,
            crate::limits::WORLD_HALF_EXTENT_M,
            "the world size",
        )
    }

    /// A point in a link or object frame: three finite coordinates within
    /// [`MAX_LOCAL_OFFSET_M`](crate::limits::MAX_LOCAL_OFFSET_M) of the frame's origin.
    pub fn local_point3(&self, field: impl Fn() -> String, v: [f64; 3]) -> Result<Point3<f64>> {
        self.bounded_vec3(
            field,
            v,
            crate::limits::MAX_LOCAL_OFFSET_M,
            "the largest offset in a link or object frame",
        )
        .map(Point3::from)
    }

    fn bounded_vec3(
        &self,
        field: impl Fn() -> String,
        v: [f64; 3],
        bound: f64,
        what: &str,
    ) -> Result<Vector3<f64>> {
        let v = self.vec3(&field, v)?;
        if v.iter().any(|x| x.abs() > bound) {
            return Err(Error::invalid(
                self.path,
                field(),
                format!(
                    "is [{}, {}, {}]; expected coordinates within ±{bound} m ({what})",
                    num(v.x),
                    num(v.y),
                    num(v.z)
                ),
            ));
        }
        Ok(v)
    }

    /// A scene size [m]: a finite number > 0 no larger than the world
    /// (2 × [`WORLD_HALF_EXTENT_M`](crate::limits::WORLD_HALF_EXTENT_M)).
    pub fn size(&self, field: impl Fn() -> String, v: f64) -> Result<f64> {
        self.positive(&field, v, "m")?;
        let world = 2.0 * crate::limits::WORLD_HALF_EXTENT_M;
        if v > world {
            return Err(Error::invalid(
                self.path,
                field(),
                format!(
                    "is {} m; expected at most {world} m (the world size)",
                    num(v)
                ),
            ));
        }
        Ok(v)
    }

    /// A finite number in `[lo, hi]`.
    pub fn in_range(
        &self,
        field: impl FnOnce() -> String,
        v: f64,
        (lo, hi): (f64, f64),
        unit: &str,
    ) -> Result<f64> {
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(Error::invalid(
                self.path,
                field(),
                format!(
                    "is {}; expected a number from {lo} to {hi} ({unit})",
                    num(v)
                ),
            ))
        }
    }

    /// A point with three finite coordinates.
    pub fn point3(&self, field: impl FnOnce() -> String, v: [f64; 3]) -> Result<Point3<f64>> {
        self.vec3(field, v).map(Point3::from)
    }

    /// A quaternion stored `[w, x, y, z]`, normalized if its norm is within
    /// [`QUAT_NORM_TOLERANCE`] of 1 (the rule of [`rotation::quat_from_wxyz`]).
    pub fn quaternion(
        &self,
        field: impl FnOnce() -> String,
        q: [f64; 4],
    ) -> Result<UnitQuaternion<f64>> {
        rotation::quat_from_wxyz(q).map_err(|e| {
            let message = match e {
                RotationError::NotUnit { norm, .. } if norm < 1e-12 => {
                    "is the zero quaternion; expected a unit quaternion [w, x, y, z] (identity is [1, 0, 0, 0])".to_string()
                }
                RotationError::NotUnit { norm, .. } => format!(
                    "has norm {norm:.6}; expected a unit quaternion [w, x, y, z] (norm within {QUAT_NORM_TOLERANCE} of 1)"
                ),
                _ => format!("is {q:?}; expected four finite numbers [w, x, y, z]"),
            };
            Error::invalid(self.path, field(), message)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize, Debug)]
    #[allow(dead_code)]
    struct Inner {
        link: String,
    }
    #[derive(serde::Deserialize, Debug)]
    #[allow(dead_code)]
    struct Outer {
        frames: Vec<Vec<Inner>>,
    }

    #[test]
    fn type_errors_name_the_json_path() {
        let text = br#"{"frames": [[{"link": "a"}], [{"link": "b"}, {"link": 3}]]}"#;
        let err = parse_json::<Outer>(Path::new("x.json"), text).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("x.json"), "{msg}");
        assert!(msg.contains("frames[1][1].link"), "{msg}");
        assert!(msg.contains("expected a string"), "{msg}");
    }

    #[test]
    fn unknown_keys_are_refused_with_the_nearest_known_one() {
        #[derive(Debug, serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct Config {
            barriers: Vec<String>,
            waypoints: Vec<f64>,
        }
        let text = br#"{"barrier": ["wall"], "waypoints": []}"#;
        let msg = parse_json::<Config>(Path::new("c.json"), text)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("c.json") && msg.contains("unknown field `barrier`"),
            "{msg}"
        );
        assert!(msg.ends_with("did you mean `barriers`?"), "{msg}");
        // Nothing near: no guess.
        let text = br#"{"colour": 1, "barriers": [], "waypoints": []}"#;
        let msg = parse_json::<Config>(Path::new("c.json"), text)
            .unwrap_err()
            .to_string();
        assert!(!msg.contains("did you mean"), "{msg}");
        assert_eq!(
            nearest_name("Waypoint", &["barriers", "waypoints"]),
            Some("waypoints")
        );
    }

    #[test]
    fn syntax_errors_give_position_and_nan_hint() {
        let text = b"{\"frames\": [NaN]}";
        let msg = parse_json::<Outer>(Path::new("x.json"), text)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("line 1, column"), "{msg}");
        assert!(msg.contains("no NaN"), "{msg}");
    }

    #[test]
    fn quaternions_are_normalized_or_refused() {
        let c = FieldCheck::new(Path::new("d.json"));
        let q = c
            .quaternion(|| "q".into(), [1.0005, 0.0, 0.0, 0.0])
            .unwrap();
        assert!((q.quaternion().norm() - 1.0).abs() < 1e-12);
        let zero = c.quaternion(|| "frames[2].object.orientation".into(), [0.0; 4]);
        let msg = zero.unwrap_err().to_string();
        assert!(msg.contains("frames[2].object.orientation") && msg.contains("zero quaternion"));
        let far = c
            .quaternion(|| "q".into(), [2.0, 0.0, 0.0, 0.0])
            .unwrap_err();
        assert!(far.to_string().contains("norm 2.000000"), "{far}");
    }

    #[test]
    fn atomic_write_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/report.json");
        write_json_atomic(&p, &serde_json::json!({"a": 1})).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "{\n  \"a\": 1\n}\n");
        let names: Vec<_> = std::fs::read_dir(p.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }
}
