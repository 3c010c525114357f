//! Walking and editing YAML documents by dotted key path, for the
//! table-driven bad-configuration tests (the same path syntax the loaders
//! print: `barrier.d_safe_m`, `world.boxes[0].center`).
#![allow(dead_code)]

use serde_yaml::Value;

/// One step of a key path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Seg {
    Key(String),
    Index(usize),
}

/// A path as the loaders print it.
pub fn show(path: &[Seg]) -> String {
    let mut s = String::new();
    for seg in path {
        match seg {
            Seg::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            Seg::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// The path with every index replaced by `[]` (one table row per such key).
pub fn normalized(path: &[Seg]) -> String {
    show(path)
        .split('[')
        .enumerate()
        .map(|(i, part)| {
            if i == 0 {
                part.to_string()
            } else {
                format!("[]{}", part.split_once(']').map_or("", |(_, rest)| rest))
            }
        })
        .collect()
}

/// Every leaf: a scalar, or a sequence of scalars (e.g. `[1.0, 2.0]`), with its path.
pub fn leaves(v: &Value) -> Vec<Vec<Seg>> {
    fn walk(v: &Value, path: &mut Vec<Seg>, out: &mut Vec<Vec<Seg>>) {
        match v {
            Value::Mapping(m) => {
                for (k, x) in m {
                    path.push(Seg::Key(k.as_str().expect("string keys").to_string()));
                    walk(x, path, out);
                    path.pop();
                }
            }
            Value::Sequence(s) if s.iter().any(|x| x.is_mapping() || x.is_sequence()) => {
                for (i, x) in s.iter().enumerate() {
                    path.push(Seg::Index(i));
                    walk(x, path, out);
                    path.pop();
                }
            }
            _ => out.push(path.clone()),
        }
    }
    let mut out = Vec::new();
    walk(v, &mut Vec::new(), &mut out);
    out
}

/// The slot at `path`.
pub fn get_mut<'a>(v: &'a mut Value, path: &[Seg]) -> &'a mut Value {
    let mut slot = v;
    for seg in path {
        slot = match seg {
            Seg::Key(k) => slot.get_mut(k.as_str()).unwrap_or_else(|| panic!("no key {k}")),
            Seg::Index(i) => slot.get_mut(*i).unwrap_or_else(|| panic!("no index {i}")),
        };
    }
    slot
}

/// `doc` with the value at `path` replaced by `yaml`.
pub fn with(doc: &Value, path: &[Seg], yaml: &str) -> Value {
    let mut v = doc.clone();
    *get_mut(&mut v, path) = serde_yaml::from_str(yaml).expect("test value is YAML");
    v
}

/// `doc` without the key at `path` (the last segment must be a key).
pub fn without(doc: &Value, path: &[Seg]) -> Value {
    let mut v = doc.clone();
    let (last, parent) = path.split_last().expect("non-empty path");
    let Seg::Key(k) = last else {
        panic!("not a key: {}", show(path))
    };
    get_mut(&mut v, parent)
        .as_mapping_mut()
        .expect("parent is a mapping")
        .remove(k.as_str());
    v
}

/// `doc` with an unknown key `<leaf>_typo: 1` beside the leaf at `path`;
/// returns the new key's path.
pub fn with_sibling(doc: &Value, path: &[Seg]) -> (Value, String) {
    let mut v = doc.clone();
    let (last, parent) = path.split_last().expect("non-empty path");
    let Seg::Key(k) = last else {
        panic!("not a key: {}", show(path))
    };
    let name = format!("{k}_typo");
    get_mut(&mut v, parent)
        .as_mapping_mut()
        .expect("parent is a mapping")
        .insert(Value::String(name.clone()), Value::from(1));
    let mut p = parent.to_vec();
    p.push(Seg::Key(name));
    (v, show(&p))
}

/// The path of a mapping's leaf as segments (`a.b.c`; no indices).
pub fn path(dotted: &str) -> Vec<Seg> {
    dotted.split('.').map(|k| Seg::Key(k.to_string())).collect()
}
