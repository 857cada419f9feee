//! JSON as the dataset's files hold it: 4-space indentation (as LeRobot writes), keys in a fixed order, floats in
//! their shortest round-trip form, so the same values always give the same bytes.

use crate::error::DatasetError;
use serde::ser::{Serialize, SerializeMap, Serializer};
use std::path::Path;

/// A map written in its entries' order.
#[derive(Clone, Debug, PartialEq)]
pub struct Ordered<V>(pub Vec<(String, V)>);

impl<V: Serialize> Serialize for Ordered<V> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

/// Pretty JSON with 4-space indentation and a final newline.
pub fn to_bytes<T: Serialize>(path: &Path, value: &T) -> Result<Vec<u8>, DatasetError> {
    let mut out = Vec::new();
    let fmt = serde_json::ser::PrettyFormatter::with_indent(b"    ");
    let mut ser = serde_json::Serializer::with_formatter(&mut out, fmt);
    value
        .serialize(&mut ser)
        .map_err(|e| DatasetError::json(path, e))?;
    out.push(b'\n');
    Ok(out)
}

/// Reads and parses a JSON file; errors name the file.
pub fn read<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, DatasetError> {
    let bytes = std::fs::read(path).map_err(|e| DatasetError::io(path, e))?;
    serde_json::from_slice(&bytes)
        .map_err(|e| DatasetError::json(path, format!("invalid JSON: {e}")))
}
