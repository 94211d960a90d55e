//! The binary message the page reads: a JSON header followed by float32 arrays, so large
//! trajectories cross the socket without text encoding. Layout: a little-endian u32 with the
//! header's length, the UTF-8 JSON header padded with spaces to a multiple of 4 bytes, then
//! every array's values (little-endian f32) in order; the header's `arrays` list gives each
//! array's `name`, `shape` and `offset` (in values from the start of the data).

use serde_json::{json, Map, Value};

/// A message under construction: header fields and arrays.
#[derive(Debug, Default, Clone)]
pub struct Blob {
    header: Map<String, Value>,
    arrays: Vec<(String, Vec<usize>, Vec<f32>)>,
}

impl Blob {
    /// An empty message.
    pub fn new() -> Self {
        Self::default()
    }

    /// Set a header field (any key but `arrays`).
    pub fn set(&mut self, key: &str, value: Value) {
        self.header.insert(key.to_string(), value);
    }

    /// Append an array; `values.len()` must be the product of `shape` (checked: a mismatch is
    /// a programming error and the array is dropped in release builds).
    pub fn push(&mut self, name: impl Into<String>, shape: Vec<usize>, values: Vec<f32>) {
        debug_assert_eq!(shape.iter().product::<usize>(), values.len());
        if shape.iter().product::<usize>() == values.len() {
            self.arrays.push((name.into(), shape, values));
        }
    }

    /// The encoded message.
    pub fn encode(&self) -> Vec<u8> {
        let mut header = self.header.clone();
        let mut offset = 0usize;
        let list: Vec<Value> = self
            .arrays
            .iter()
            .map(|(name, shape, values)| {
                let v = json!({"name": name, "shape": shape, "offset": offset});
                offset += values.len();
                v
            })
            .collect();
        header.insert("arrays".into(), Value::Array(list));
        let mut text = serde_json::to_vec(&Value::Object(header)).expect("JSON of plain values");
        while text.len() % 4 != 0 {
            text.push(b' ');
        }
        let mut out = Vec::with_capacity(4 + text.len() + 4 * offset);
        out.extend((text.len() as u32).to_le_bytes());
        out.extend(&text);
        for (_, _, values) in &self.arrays {
            for v in values {
                out.extend(v.to_le_bytes());
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_then_aligned_values() {
        let mut b = Blob::new();
        b.set("type", json!("frame"));
        b.push("a", vec![2], vec![1.0, 2.0]);
        b.push("b", vec![1, 1], vec![3.5]);
        let bytes = b.encode();
        let len = u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize;
        assert_eq!(len % 4, 0);
        let header: Value = serde_json::from_slice(&bytes[4..4 + len]).unwrap();
        assert_eq!(header["type"], "frame");
        assert_eq!(header["arrays"][1]["offset"], 2);
        let data = &bytes[4 + len..];
        assert_eq!(data.len(), 12);
        assert_eq!(f32::from_le_bytes(data[8..12].try_into().unwrap()), 3.5);
    }
}
